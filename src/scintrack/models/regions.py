"""Scintillation intensity regions of Vila-Valls et al. 2018, Sec. III-A.

``S4 <= 0.3`` weak ("low" in Table I), ``0.3 < S4 <= 0.6`` moderate,
``0.6 < S4`` severe.
"""

from __future__ import annotations

REGIONS = (
    ("severe", 0.6, float("inf")),
    ("moderate", 0.3, 0.6),
    ("low", float("-inf"), 0.3),
)


def region_of(s4: float) -> str:
    """Name of the region that contains ``s4`` (lower bound open, upper closed)."""
    for name, lo, hi in REGIONS:
        if lo < s4 <= hi:
            return name
    raise ValueError(f"S4={s4} is in no region")
