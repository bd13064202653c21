"""The conventions every figure follows, in one place.

A reader should never have to guess what a line, an axis or a colour means:

* **Legends off the data**: :func:`legend_outside` puts an axes' legend to its
  right or below it (``tight_layout`` makes room), :func:`figure_legend` puts
  one legend for several panels (:func:`handles_of`) below them all, and
  :func:`caption` adds explanatory lines below the panels.
* **Readable ticks**: :func:`log_ticks` labels a log axis at 1-2-5 steps (every
  integer step when the axis spans less than a decade) with plain numbers, so
  1.1-1.6 rad can be read; :func:`~.common.symlog_axis` does the same for a
  symmetric-log axis.
* **One error convention per axis, with its "no lock" level drawn**: a wrapped
  phase error that carries no information left is uniform on its wrapping
  interval, whose RMSE is the interval's width over sqrt(12):
  ``pi/sqrt(3) = 1.81 rad`` for an error wrapped to (-pi, pi] (a four-quadrant
  discriminator, Vila-Valls's metric) and ``pi/(2 sqrt(3)) = 0.907 rad`` for an
  error wrapped to (-pi/2, pi/2] (a Costas loop that cannot tell a data bit from
  half a cycle).  :func:`no_lock_level` draws that level on the axis it belongs
  to; two conventions never share one axis.
* **Lost lock marked, not plotted as an error**: :func:`until_lock_lost` cuts a
  trace where the loop left its lock region for good, and :func:`mark_lock_lost`
  puts a cross and a label there, so a loop that ran away (an unwrapped error
  of 10^8 cycles) does not squeeze the informative traces into a corner.
* **Synthetic data named**: :func:`data_title` is the words every title of a
  figure drawn from synthetic data carries (the file name carries the matching
  tag, :meth:`scintrack.products.registry.Product.suffix`).
* **Readable text**: nothing smaller than :data:`MIN_FONT_PT` at the figure's
  print size (its ``figsize``); :mod:`scintrack.products.figure_check` checks
  every rendered figure against these rules.
"""

from __future__ import annotations

import math

import numpy as np

#: smallest font (points, at the figure's print size) any text may have
MIN_FONT_PT = 7.0

#: RMSE of an error uniform on (-pi, pi]: a four-quadrant loop without lock
NO_LOCK_RMSE_2PI = math.pi / math.sqrt(3.0)
#: RMSE of an error uniform on (-pi/2, pi/2]: a Costas (data-aided-free) loop without lock
NO_LOCK_RMSE_PI = math.pi / (2.0 * math.sqrt(3.0))

#: what each kind of data is called in a figure's title
DATA_WORDS = {
    "synthetic CSM": "synthetic CSM data",
    "surrogate": "SYNTHETIC SURROGATE traces (not the real recordings)",
    "synthetic SKYDEL-like": "SYNTHETIC SKYDEL-like data",
    "real": "real recordings",
    "mixed": "synthetic CSM, SKYDEL-like and trace data",
}


def data_title(kind: str) -> str:
    """The words naming the data of a figure in its title (``DATA_WORDS``)."""
    try:
        return DATA_WORDS[kind]
    except KeyError:
        raise ValueError(f"unknown data kind {kind!r}; known: {', '.join(DATA_WORDS)}") from None


def legend_outside(ax, where: str = "right", **kwargs):
    """The legend of ``ax`` beside it (``where="right"``) or below it (``"below"``), never on the data."""
    if where == "right":
        place = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "borderaxespad": 0.0}
    elif where == "below":
        place = {"loc": "upper center", "bbox_to_anchor": (0.5, -0.18), "borderaxespad": 0.0,
                 "ncol": kwargs.pop("ncol", 3)}
    else:
        raise ValueError(f"legend_outside: where must be 'right' or 'below', not {where!r}")
    place.update(kwargs)
    return ax.legend(**place)


def figure_legend(fig, handles, labels, *, ncol: int = 3, **kwargs):
    """One legend for the whole figure, below every panel (call after ``tight_layout``).

    The legend is drawn once to measure its height and put in that much room made below the panels
    (:func:`~.common.room_below`), so it covers nothing.  Labels too long for a column are wrapped."""
    import textwrap

    from .common import room_below

    if not handles:
        return None
    fontsize = kwargs.pop("fontsize", 8)
    width_in = fig.get_size_inches()[0]
    chars = max(int(width_in * 72 / (0.6 * fontsize) / ncol) - 6, 12)
    labels = ["\n".join(textwrap.wrap(str(lab), chars)) or str(lab) for lab in labels]
    legend = fig.legend(handles, labels, loc="lower center", ncol=ncol, fontsize=fontsize, frameon=False,
                        bbox_transform=fig.transFigure, **kwargs)
    fig.draw_without_rendering()
    total = room_below(fig, legend.get_window_extent(fig.canvas.get_renderer()).height / fig.dpi + 6 / 72)
    legend.set_bbox_to_anchor((0.5, 3 / 72 / total), transform=fig.transFigure)
    return legend


def handles_of(*axes) -> tuple[list, list[str]]:
    """The legend handles and labels of ``axes``, each label once, in drawing order (for :func:`figure_legend`)."""
    handles, labels = [], []
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            if lab not in labels and not lab.startswith("_"):
                handles.append(h)
                labels.append(lab)
    return handles, labels


def caption(fig, text: str, *, fontsize: float = 7.5) -> None:
    """Explanatory lines below the panels in the text colour (call after ``tight_layout`` and before
    :func:`figure_legend`, which then goes below them), in room made for them (:func:`~.common.room_below`).
    (:func:`~.common.add_footer` is the red note of the numerical guards, added below everything by the
    render rule.)"""
    import textwrap

    from .common import room_below

    if not text:
        return
    width_in = fig.get_size_inches()[0]
    chars = max(int(width_in * 72 / (0.55 * fontsize)) - 6, 40)
    lines = [line for para in text.split("\n") for line in textwrap.wrap(para, chars)]
    total = room_below(fig, (len(lines) * 1.3 * fontsize + 8) / 72)
    fig.text(0.02, 3 / 72 / total, "\n".join(lines), fontsize=fontsize, ha="left", va="bottom")


def log_ticks(ax, axis: str = "y") -> None:
    """Plain-number labels on a log ``axis``: evenly spaced round numbers (0.6, 0.8,
    1, 1.2 ...) when it spans less than a decade, 1-1.5-2-3-5-7 steps up to two
    decades, 1-2-5 steps up to three, decades beyond.  Call after the axis
    limits are final."""
    from matplotlib.ticker import FuncFormatter, LogLocator, MaxNLocator, NullFormatter

    a = ax.yaxis if axis == "y" else ax.xaxis
    lo, hi = sorted(ax.get_ylim() if axis == "y" else ax.get_xlim())
    span = math.log10(hi / lo) if lo > 0 else 3.0
    if span < 1.0:
        a.set_major_locator(MaxNLocator(nbins=8, steps=[1, 2, 2.5, 5, 10]))
    else:
        subs = (1.0, 1.5, 2.0, 3.0, 5.0, 7.0) if span < 2.0 else (1.0, 2.0, 5.0) if span < 3.0 else (1.0,)
        a.set_major_locator(LogLocator(base=10, subs=subs))
    a.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
    a.set_minor_formatter(NullFormatter())


def no_lock_level(ax, level: float = NO_LOCK_RMSE_2PI, *, label: str | None = None, color: str = "0.35") -> None:
    """The RMSE of a wrapped error without lock, drawn as a dashed line with its value."""
    if label is None:
        label = "no lock: " + ("$\\pi/\\sqrt{3}$" if math.isclose(level, NO_LOCK_RMSE_2PI) else
                               "$\\pi/(2\\sqrt{3})$" if math.isclose(level, NO_LOCK_RMSE_PI) else "") + f" = {level:.2f} rad"
    ax.axhline(level, color=color, ls="--", lw=1.0, zorder=1)
    ax.annotate(label, xy=(1.0, level), xycoords=("axes fraction", "data"), xytext=(-3, 2), textcoords="offset points",
                ha="right", va="bottom", fontsize=MIN_FONT_PT, color=color)


def until_lock_lost(t: np.ndarray, error: np.ndarray, bound: float) -> tuple[np.ndarray, float | None]:
    """``error`` with NaN from the first epoch its magnitude exceeds ``bound`` for good, and that time.

    "For good": the error never comes back within ``bound`` afterwards (a loop
    that slipped a cycle and relocked is still tracking and is drawn whole).
    Returns the cut trace and the time lock was lost (None when it never was).
    """
    err = np.asarray(error, dtype=float)
    inside = np.abs(err) <= bound
    if inside[-1] if err.size else True:
        return err, None
    last_in = np.flatnonzero(inside)
    k = int(last_in[-1]) + 1 if last_in.size else 0
    out = err.copy()
    out[k:] = np.nan
    return out, float(np.asarray(t)[k])


def mark_lock_lost(ax, t_lost: float | None, y: float, *, color: str, label: str = "lock lost") -> None:
    """A cross at ``(t_lost, y)`` with ``label`` (nothing when lock was never lost)."""
    if t_lost is None:
        return
    ax.plot([t_lost], [y], marker="x", ms=8, mew=2, color=color, ls="none", zorder=5)
    ax.annotate(f"{label} ({t_lost:g} s)", xy=(t_lost, y), xytext=(4, 4), textcoords="offset points", fontsize=MIN_FONT_PT,
                color=color)
