"""Writing tables as CSV and Markdown with a stated number of digits."""

from __future__ import annotations

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
