"""The layout check every rendered figure passes (the rules of :mod:`.figures.conventions`).

Built on matplotlib's own layout objects: the figure is drawn once without
rendering pixels, then every text's, legend's and line's extent is read in
display space (pixels at the figure's dpi) and compared with the canvas and
with each other.  The rules, each named in the problems it reports:

* ``text-outside``: no visible text reaches beyond the canvas;
* ``title-too-wide``: no axes title or figure title is wider than the figure;
* ``legend-on-data``: no legend box covers more than :data:`LEGEND_SHARE` of the
  points of any line drawn in an axes (a line is sampled densely along its
  segments, so a two-point reference line counts by its length);
* ``few-ticks``: every shown axis has at least two labelled ticks within its view (an axis whose
  ticks were all removed on purpose, such as a colorbar's short side, shows no scale and is skipped);
* ``small-font``: no visible text is smaller than
  :data:`~.figures.conventions.MIN_FONT_PT` points at the figure's print size
  (its ``figsize``).

:func:`check_figure` returns the problems (empty when the figure passes); the
figure rule records them beside the figure (``<stem>.json``, key
``layout_problems``) and the test suite requires every figure of the smoke
build to have none.
"""

from __future__ import annotations

import numpy as np

from .figures.conventions import MIN_FONT_PT

#: largest share of a line's points a legend box may cover
LEGEND_SHARE = 0.02
#: slack (pixels) for text touching the canvas edge
EDGE_PX = 1.0
#: a line with fewer samples than this is resampled along its segments
DENSE = 400


def _walk(artist, axis=None):
    """Every visible artist under ``artist`` (an invisible one hides its children; a tick outside its axis's
    view is not drawn)."""
    from matplotlib.axis import Axis, Tick

    if not artist.get_visible():
        return
    if isinstance(artist, Tick) and axis is not None:
        lo, hi = sorted(axis.get_view_interval())
        pad = 1e-9 * max(abs(hi - lo), 1e-300)
        if not lo - pad <= artist.get_loc() <= hi + pad:
            return
    yield artist
    for child in artist.get_children():
        yield from _walk(child, artist if isinstance(artist, Axis) else axis)


def _visible_texts(fig):
    from matplotlib.text import Text

    for a in _walk(fig):
        if isinstance(a, Text) and a.get_text().strip():
            yield a


def _drawn(t, renderer) -> bool:
    """Whether ``t`` is drawn at all: a clipped text outside its clip box is not."""
    if not t.get_clip_on() or t.get_clip_box() is None:
        return True
    return t.get_window_extent(renderer).overlaps(t.get_clip_box())


def _dense(points: np.ndarray) -> np.ndarray:
    if len(points) >= DENSE or len(points) < 2:
        return points
    per = int(np.ceil(DENSE / (len(points) - 1)))
    s = np.linspace(0.0, 1.0, per, endpoint=False)
    a, b = points[:-1], points[1:]
    out = (a[:, None, :] + (b - a)[:, None, :] * s[None, :, None]).reshape(-1, 2)
    return np.vstack([out, points[-1:]])


def _line_points(line, ax_box) -> np.ndarray:
    xy = np.asarray(line.get_xydata(), dtype=float)
    if xy.size == 0:
        return xy.reshape(0, 2)
    disp = line.get_transform().transform(xy)
    disp = disp[np.isfinite(disp).all(axis=1)]
    disp = _dense(disp)
    inside = ((disp[:, 0] >= ax_box.x0) & (disp[:, 0] <= ax_box.x1) & (disp[:, 1] >= ax_box.y0) & (disp[:, 1] <= ax_box.y1))
    return disp[inside]


def _short(text: object) -> str:
    """``text`` on one line, cut to 40 characters (how a problem names a text, line or axes)."""
    text = " ".join(str(text).split())
    return text if len(text) <= 40 else text[:37] + "..."


def _label_of(artist) -> str:
    return _short(artist.get_text() if hasattr(artist, "get_text") else artist.get_label())


def check_figure(fig, dpi: float | None = None) -> list[str]:
    """Every layout problem of ``fig`` as ``"<rule>: <what>"`` (empty: the figure passes).

    ``dpi``: measure at the resolution the figure is saved at (text is hinted
    to the pixel grid, so its width is not exactly proportional to the dpi);
    the figure's own dpi is restored afterwards."""
    if dpi is not None and dpi != fig.dpi:
        own = fig.dpi
        fig.set_dpi(dpi)
        try:
            return check_figure(fig)
        finally:
            fig.set_dpi(own)
    fig.draw_without_rendering()
    renderer = fig.canvas.get_renderer()
    canvas = fig.bbox
    problems: list[str] = []

    titles = {id(ax.title) for ax in fig.axes} | {id(t) for t in fig.texts}
    for t in _visible_texts(fig):
        if not _drawn(t, renderer):
            continue
        box = t.get_window_extent(renderer)
        if (box.x0 < canvas.x0 - EDGE_PX or box.y0 < canvas.y0 - EDGE_PX or box.x1 > canvas.x1 + EDGE_PX
                or box.y1 > canvas.y1 + EDGE_PX):
            problems.append(f"text-outside: {_label_of(t)!r} reaches beyond the canvas")
        if id(t) in titles and box.width > canvas.width:
            problems.append(f"title-too-wide: {_label_of(t)!r} is {box.width / canvas.width:.2f} figure widths wide")
        if t.get_fontsize() < MIN_FONT_PT - 1e-9:
            problems.append(f"small-font: {_label_of(t)!r} is {t.get_fontsize():g} pt (at least {MIN_FONT_PT:g})")

    legends = [lg for lg in [*fig.legends, *(ax.get_legend() for ax in fig.axes)] if lg is not None and lg.get_visible()]
    for lg in legends:
        lbox = lg.get_window_extent(renderer)
        for ax in fig.axes:
            ax_box = ax.get_window_extent(renderer)
            for line in ax.get_lines():
                if not line.get_visible():
                    continue
                pts = _line_points(line, ax_box)
                if len(pts) == 0:
                    continue
                covered = np.mean((pts[:, 0] >= lbox.x0) & (pts[:, 0] <= lbox.x1) & (pts[:, 1] >= lbox.y0) & (pts[:, 1] <= lbox.y1))
                if covered > LEGEND_SHARE:
                    problems.append(f"legend-on-data: a legend covers {covered:.0%} of line {_label_of(line)!r}")

    for ax in fig.axes:
        if not ax.get_visible() or not ax.axison:
            continue
        for name, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            if not axis.get_visible() or _no_scale(axis):
                continue
            lo, hi = sorted(axis.get_view_interval())
            span = hi - lo
            labelled = [lab for loc, lab in zip(axis.get_majorticklocs(), axis.get_majorticklabels())
                        if lo - 1e-9 * abs(span) <= loc <= hi + 1e-9 * abs(span) and lab.get_visible() and lab.get_text().strip()]
            if len(labelled) < 2:
                where = ax.get_title() or ax.get_ylabel() or ax.get_xlabel() or "an axes"
                problems.append(f"few-ticks: the {name} axis of {_short(where)!r} has {len(labelled)} labelled tick(s)")
    return sorted(set(problems))


def _no_scale(axis) -> bool:
    """An axis whose ticks were all removed on purpose (``set_xticks([])``: a colorbar's short side, an
    image's side) shows no scale and is not checked."""
    from matplotlib.ticker import FixedLocator

    locator = axis.get_major_locator()
    return isinstance(locator, FixedLocator) and len(locator.locs) == 0
