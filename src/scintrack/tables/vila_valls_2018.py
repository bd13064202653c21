"""Tables of Vila-Valls et al. 2018, one function per table."""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr

from ..models.regions import REGIONS
from .paper_values import VILA_VALLS_2018_TABLE_I


def _order_summary(orders: np.ndarray) -> tuple[int, float, int, int]:
    """Modal order (ties to the lower), its share, min and max."""
    vals, counts = np.unique(orders, return_counts=True)
    mode = int(vals[np.argmax(counts)])
    return mode, float(counts.max() / counts.sum()), int(vals.min()), int(vals.max())


def _regions(lut: xr.Dataset):
    s4 = lut["s4"].values
    for region, lo, hi in REGIONS:
        in_region = s4[(s4 > lo) & (s4 <= hi)]
        if in_region.size:
            yield region, in_region


def table01_by_length(lut: xr.Dataset) -> pd.DataFrame:
    """Supplement to Table I: PACF-rule order against the length of the series."""
    rows = []
    sel = lut["trial_pacf_order_by_length"]
    for region, in_region in _regions(lut):
        for component, sym in (("amplitude", "q"), ("phase", "p")):
            row = {"region": region, "order": sym, "paper": VILA_VALLS_2018_TABLE_I[region][component]}
            for length in sel["pacf_length"].values:
                orders = sel.sel(s4=in_region, component=component, pacf_length=length).values.ravel()
                mode, share, lo_o, hi_o = _order_summary(orders)
                band = 1.959964 / np.sqrt(length / float(lut.attrs["ts"]))
                row[f"{length:g} s (band +-{band:.3f})"] = f"AR({mode}) [{share:.0%}; {lo_o}-{hi_o}]"
            rows.append(row)
    return pd.DataFrame(rows)


def table01_long(lut: xr.Dataset) -> pd.DataFrame:
    """Table I in long form: region x component x criterion, over all fits in the region."""
    rows = []
    sel = lut["trial_selected_order"]
    for region, in_region in _regions(lut):
        for component in ("amplitude", "phase"):
            paper = VILA_VALLS_2018_TABLE_I[region][component]
            for criterion in sel["criterion"].values:
                orders = sel.sel(s4=in_region, component=component, criterion=criterion).values.ravel()
                mode, share, lo_o, hi_o = _order_summary(orders)
                rows.append(
                    {
                        "region": region,
                        "s4_grid": " ".join(f"{v:g}" for v in in_region),
                        "component": component,
                        "symbol": "q" if component == "amplitude" else "p",
                        "criterion": str(criterion),
                        "paper_order": paper,
                        "modal_order": mode,
                        "share_of_fits": round(share, 3),
                        "min_order": lo_o,
                        "max_order": hi_o,
                        "n_fits": int(orders.size),
                        "matches_paper": bool(mode == paper),
                    }
                )
    return pd.DataFrame(rows)


def table01_twin(long: pd.DataFrame) -> pd.DataFrame:
    """Paper beside reproduction: one row per region, q and p by criterion."""
    rows = []
    for region, grp in long.groupby("region", sort=False):
        row = {"region": region, "S4 range": VILA_VALLS_2018_TABLE_I[region]["s4_range"]}
        for component, sym in (("amplitude", "q"), ("phase", "p")):
            sub = grp[grp.component == component].set_index("criterion")
            row[f"{sym} paper"] = f"AR({VILA_VALLS_2018_TABLE_I[region][component]})"
            for crit in ("pacf", "aic", "bic"):
                r = sub.loc[crit]
                row[f"{sym} {crit.upper()}"] = f"AR({r.modal_order}) [{r.share_of_fits:.0%}; {r.min_order}-{r.max_order}]"
        rows.append(row)
    return pd.DataFrame(rows)
