"""One page listing every reproduced table cell beside the paper's value.

Reads the ``*_vs_paper.csv`` twins, groups them by paper and table, and adds a
summary line: cells whose paper value lies inside our 95% interval, cells
within 25% of it, cells beyond.  Table I (AR orders) enters from its long
form: the paper's order against our modal order, with the range of orders
over all fits in place of an interval.  Written as Markdown and as a standalone HTML
page (pandas' HTML writer).
"""

from __future__ import annotations

import html
from collections.abc import Iterable
from pathlib import Path

import numpy as np
import pandas as pd

PAPERS = {
    "vila_valls_2018": "Vilà-Valls et al. 2018, IEEE TAES 54(4), doi:10.1109/TAES.2018.2798480",
    "zhao_jamming": "Zhao, Khanafseh & Pervan, MM Kalman filter through wideband jamming (synthetic SKYDEL-like data)",
}


def _verdict(row) -> str:
    if not np.isfinite(row["paper"]):
        return "no paper value"
    if row["paper_within_ci95"]:
        return "within 95% CI"
    if row["paper"] != 0 and abs(row["reproduced"] / row["paper"] - 1) <= 0.25:
        return "within 25%"
    return "beyond"


def _orders_as_cells(df: pd.DataFrame) -> pd.DataFrame:
    """Table I (AR orders): paper order vs our modal order; the 'interval' is the range of orders over all fits."""
    return pd.DataFrame(
        {
            "row": df["region"],
            "column": df["symbol"] + " " + df["criterion"].astype(str),
            "paper": df["paper_order"].astype(float),
            "reproduced": df["modal_order"].astype(float),
            "ci95_lo": df["min_order"].astype(float),
            "ci95_hi": df["max_order"].astype(float),
            "ratio_reproduced_over_paper": df["modal_order"] / df["paper_order"],
            "paper_within_ci95": (df["min_order"] <= df["paper_order"]) & (df["paper_order"] <= df["max_order"]),
        }
    )


def collect(paths: Iterable[str | Path]) -> pd.DataFrame:
    """Twin tables (row, column, paper, reproduced, ci95_lo, ci95_hi, ...) plus Table I's long form."""
    frames = []
    for path in sorted(map(Path, paths)):
        df = pd.read_csv(path)
        if "modal_order" in df.columns:
            df = _orders_as_cells(df)
            path = path.with_name(path.stem + "_vs_paper.csv")
        if df.empty or "paper" not in df.columns:
            continue
        df.insert(0, "table", path.stem.replace("_vs_paper", ""))
        df.insert(0, "paper_key", path.parent.name)
        df["verdict"] = df.apply(_verdict, axis=1)
        frames.append(df)
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


def summary(df: pd.DataFrame) -> str:
    counts = df["verdict"].value_counts()
    n = int((df["verdict"] != "no paper value").sum())
    return (f"{n} cells with a paper value: {counts.get('within 95% CI', 0)} within our 95% interval, "
            f"{counts.get('within 25%', 0)} more within 25%, {counts.get('beyond', 0)} beyond.")


def render(df: pd.DataFrame) -> tuple[str, str]:
    """(Markdown, HTML) of the comparison page."""
    md = ["# Paper vs reproduced: every table cell", "", "**" + summary(df) + "**", ""]
    parts = [f"<h1>Paper vs reproduced: every table cell</h1><p><b>{html.escape(summary(df))}</b></p>"]
    cols = ["row", "column", "paper", "reproduced", "ci95_lo", "ci95_hi", "ratio_reproduced_over_paper", "verdict"]
    for key, by_paper in df.groupby("paper_key", sort=True):
        title = PAPERS.get(key, key)
        md += [f"## {title}", "", summary(by_paper), ""]
        parts.append(f"<h2>{html.escape(title)}</h2><p>{html.escape(summary(by_paper))}</p>")
        for table, t in by_paper.groupby("table", sort=True):
            label = table + ("  (SURROGATE data: shapes and orderings only)" if table.endswith("_surrogate") else "")
            md += [f"### {label}", "", summary(t), "", t[cols].to_markdown(index=False, floatfmt=".3g"), ""]
            parts.append(f"<h3>{html.escape(label)}</h3><p>{html.escape(summary(t))}</p>" + t[cols].to_html(index=False, float_format=lambda v: f"{v:.3g}", na_rep="-"))
    page = ("<!DOCTYPE html><html><head><meta charset='utf-8'><title>Paper vs reproduced</title>"
            "<style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse;font-size:12px}"
            "td,th{border:1px solid #ccc;padding:2px 6px}</style></head><body>" + "".join(parts) + "</body></html>\n")
    return "\n".join(md) + "\n", page
