"""Writing tables as CSV and Markdown with a stated number of digits, and estimates with their intervals as text.

An interval needs the spread over at least two trials; with fewer its bounds
are NaN (:mod:`scintrack.experiments.metrics`) and a cell says so in words
(:data:`NO_INTERVAL`) instead of printing ``[nan, nan]`` or a zero-width
``[x, x]``.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import pandas as pd

from ...io import write_text


def to_markdown(df: pd.DataFrame, floatfmt: str = ".3g") -> str:
    """GitHub-flavoured Markdown table (tabulate, shipped with Snakemake)."""
    from tabulate import tabulate

    return tabulate(df, headers="keys", tablefmt="github", showindex=False, floatfmt=floatfmt) + "\n"


def write_table(df: pd.DataFrame, csv_path: str | os.PathLike, md_path: str | os.PathLike, *, title: str, note: str = "", floatfmt: str = ".3g") -> list[Path]:
    """CSV (full precision of the frame, ``%.6g``) and Markdown with title and note."""
    write_text(df.to_csv(index=False, float_format="%.6g", lineterminator="\n"), csv_path)
    md = f"# {title}\n\n" + to_markdown(df, floatfmt) + (f"\n{note}\n" if note else "")
    write_text(md, md_path)
    return [Path(csv_path), Path(md_path)]


def join_notes(*notes: str) -> str:
    """The non-empty notes, separated by a space (a table's own note, then the numerical-guard note of
    :func:`scintrack.experiments.guards.divergence_note`, which the render rule adds to every table)."""
    return " ".join(n.strip() for n in notes if n and n.strip())


#: what a cell shows in place of a 95% interval that does not exist (NaN bounds: fewer than two trials)
NO_INTERVAL = "no interval from fewer than two trials"


def has_interval(lo: float, hi: float) -> bool:
    """Whether both bounds of an interval are finite numbers."""
    return math.isfinite(float(lo)) and math.isfinite(float(hi))


def interval_text(lo: float, hi: float, spec: str = ".3g") -> str:
    """``[lo, hi]`` with the format ``spec``, or :data:`NO_INTERVAL` when a bound is not finite."""
    return f"[{lo:{spec}}, {hi:{spec}}]" if has_interval(lo, hi) else NO_INTERVAL


def estimate_text(m: float, lo: float, hi: float, spec: str = ".3g") -> str:
    """``m [lo, hi]``, or ``m (no interval from ...)`` when a bound is not finite (a NaN estimate keeps its bounds as they are)."""
    if math.isfinite(float(m)) and not has_interval(lo, hi):
        return f"{m:{spec}} ({NO_INTERVAL})"
    return f"{m:{spec}} [{lo:{spec}}, {hi:{spec}}]"
