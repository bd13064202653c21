"""Paper-vs-reproduced twins: the paper's value, ours, our 95% interval, the ratio."""

from __future__ import annotations

import math

import pandas as pd


def twin_rows(cells) -> pd.DataFrame:
    """``cells``: iterable of dicts with row, column, paper, ours, lo, hi (paper may be None)."""
    rows = []
    for c in cells:
        paper = c.get("paper")
        ours = float(c["ours"])
        ratio = ours / paper if paper not in (None, 0) and math.isfinite(ours) else float("nan")
        inside = paper is not None and c["lo"] <= paper <= c["hi"]
        rows.append(
            {
                "row": c["row"],
                "column": c["column"],
                "paper": paper if paper is not None else float("nan"),
                "reproduced": ours,
                "ci95_lo": float(c["lo"]),
                "ci95_hi": float(c["hi"]),
                "ratio_reproduced_over_paper": ratio,
                "paper_within_ci95": bool(inside),
            }
        )
    return pd.DataFrame(rows)
