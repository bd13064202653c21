"""Deterministic figure output and shared axis helpers.

Figures are saved as PDF and PNG with fixed metadata (no dates, no software
stamp), so the same inputs in the locked environment give the same bytes.
The ``SHA256SUMS`` manifests are written by their own rules
(:mod:`scintrack.checksums`).
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from ...atomic import atomic_write


def _pyplot():
    """matplotlib.pyplot on the Agg backend, imported on first use: building the
    Snakemake DAG imports every figure module (the product registry) and must
    not pay for matplotlib."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt

STYLE = {
    "figure.dpi": 100,
    "savefig.dpi": 150,
    "font.size": 9,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "legend.fontsize": 8,
    "svg.hashsalt": "scintrack",
    "path.simplify": False,
}

PDF_METADATA = {"CreationDate": None, "ModDate": None, "Producer": None, "Creator": "scintrack"}
PNG_METADATA = {"Software": None}


def new_figure(nrows: int = 2, ncols: int = 1, *, figsize=(6.4, 6.0), **kwargs):
    plt = _pyplot()
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(nrows, ncols, figsize=figsize, **kwargs)
    return fig, axes


def save_figure(fig, paths: Iterable[str | os.PathLike]) -> list[Path]:
    """Save ``fig`` to every path (format from the suffix), atomically; close it.

    Each file is drawn once, not twice.  matplotlib draws a figure that has a layout engine once more
    before saving it.  The engine left by ``tight_layout()`` is a placeholder that does no layout:
    it is removed first (same bytes: ``tests/test_figures_tables.py``).
    """
    from matplotlib.layout_engine import PlaceHolderLayoutEngine

    from ...io import confirm_job_code

    confirm_job_code()  # in a job: only figures of the code its rule was planned with
    if isinstance(fig.get_layout_engine(), PlaceHolderLayoutEngine):
        fig.set_layout_engine(None)
    written = []
    plt = _pyplot()
    with plt.rc_context(STYLE):
        for path in map(Path, paths):
            fmt = path.suffix.lstrip(".")
            meta = PDF_METADATA if fmt == "pdf" else PNG_METADATA if fmt == "png" else None
            atomic_write(path, lambda tmp, fmt=fmt, meta=meta: fig.savefig(tmp, format=fmt, metadata=meta))
            written.append(path)
    plt.close(fig)
    return written


def symlog_axis(ax, linthresh: float) -> None:
    """Symmetric-log y axis with plain-number tick labels: 1-2-5 steps when the
    data span little more than a decade beyond ``linthresh``, decades otherwise
    (matplotlib's default leaves most symlog ticks unlabelled)."""
    import math

    from matplotlib.ticker import FuncFormatter, SymmetricalLogLocator

    ax.set_yscale("symlog", linthresh=linthresh)
    top = max(abs(v) for v in ax.get_ylim())
    subs = [1.0, 2.0, 5.0] if math.log10(max(top, linthresh) / linthresh) <= 1.5 else [1.0]
    ax.yaxis.set_major_locator(SymmetricalLogLocator(base=10, linthresh=linthresh, subs=subs))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))


def room_below(fig, extra_in: float) -> float:
    """Make ``fig`` ``extra_in`` inches taller at the bottom, every axes, figure text (the suptitle is one)
    and figure legend keeping its place: the room below is free for a note, a caption or a legend.
    Returns the new height [in]."""
    width_in, height_in = fig.get_size_inches()
    total = height_in + extra_in

    def lift(y: float) -> float:
        return (y * height_in + extra_in) / total

    for ax in fig.axes:
        pos = ax.get_position()
        ax.set_position([pos.x0, lift(pos.y0), pos.width, pos.height * height_in / total])
    for t in fig.texts:
        if t.get_transform() == fig.transFigure:
            x, y = t.get_position()
            t.set_position((x, lift(y)))
    to_fraction = fig.transFigure.inverted()
    for legend in fig.legends:
        box = legend.get_bbox_to_anchor().transformed(to_fraction)
        legend.set_bbox_to_anchor((box.x0, lift(box.y0), box.width, box.height * height_in / total), transform=fig.transFigure)
    fig.set_size_inches(width_in, total)
    return total


def add_footer(fig, text: str, fontsize: float = 7.0) -> None:
    """Small text below everything else in ``fig`` (nothing for ""): the numerical-guard note of the results a
    figure is drawn from (:func:`scintrack.experiments.guards.divergence_note`), added to every figure by
    the render rule, so no figure drawn from a diverged run or from nan-aware S4 means can hide it.

    The note is wrapped to the figure's width and put in room made below everything (:func:`room_below`),
    so it never covers an axis label or a legend.
    """
    if not text:
        return
    import textwrap

    width_in = fig.get_size_inches()[0]
    chars = max(int(width_in * 72 / (0.6 * fontsize)) - 2, 40)  # average glyph ~0.55 em, with a margin
    lines = textwrap.wrap(text, chars)
    total = room_below(fig, (len(lines) * 1.25 * fontsize + 6) / 72)
    fig.text(0.005, 3 / 72 / total, "\n".join(lines), fontsize=fontsize, ha="left", va="bottom", color="tab:red")
