"""Vila-Valls et al. 2018, Table III: the AEKF-AR question, figures.

``figS5``: per Table III cell, the paper's AEKF-AR value, ours (95% interval
over trials) and the achievability floors of both readings with their
intervals, on a log axis (the numbers of ``tableS5_floors``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..registry import figure
from ..tables.vila_valls_2018_aekf import FLOOR_TEXT, PAPER, SECTION, floor_value, floors_inputs, pair_floors, paper_rmse, steady
from .common import new_figure

if TYPE_CHECKING:
    import xarray as xr

FLOOR_STYLE = {"riccati_steady": ("tab:blue", "s"), "riccati_time_varying": ("tab:cyan", "D"), "gls_quadratic": ("tab:orange", "^"),
               "gls_with_qd": ("tab:red", "v")}


def _bottom(series) -> float:
    """Lower y limit: half the smallest positive value or interval end drawn."""
    vals = np.concatenate([np.ravel(np.asarray(s[k], float)) for s in series for k in ("v", "lo", "hi")])
    vals = vals[np.isfinite(vals) & (vals > 0)]
    return float(vals.min()) / 2 if vals.size else 1e-3


def _errorbar(ax, x, v, lo, hi, bottom, **kw):
    """A marker with its interval on a log axis; a lower end at or below 0 is drawn to the axis bottom,
    an interval without ends as the marker alone."""
    v, lo, hi = np.asarray(v, float), np.asarray(lo, float), np.asarray(hi, float)
    has = np.isfinite(lo) & np.isfinite(hi)
    yerr = np.vstack([np.where(has, v - np.maximum(lo, bottom), 0.0), np.where(has, hi - v, 0.0)])
    ax.errorbar(x, v, yerr=np.maximum(yerr, 0.0), ls="none", capsize=2, **kw)


def _series(pairs, cells):
    """Everything drawn: paper, ours, then each floor x reading, with x offsets within a cell."""
    out = [{"v": [paper_rmse(c, "aekf_ar") for c in cells], "lo": [np.nan] * len(cells), "hi": [np.nan] * len(cells), "off": -0.38,
            "kw": {"marker": "*", "color": "k", "ms": 11, "label": "paper AEKF-AR", "zorder": 5}}]
    ours = np.array([steady(r, "aekf_ar") for r, _ in pairs])
    out.append({"v": ours[:, 0], "lo": ours[:, 1], "hi": ours[:, 2], "off": -0.28,
                "kw": {"marker": "o", "color": "0.35", "ms": 6, "label": "ours AEKF-AR [95% CI]", "zorder": 4}})
    floors, readings = list(map(str, pairs[0][1]["floor"].values)), list(map(str, pairs[0][1]["reading"].values))
    width = 0.58 / max(len(floors) * len(readings), 1)
    for k, (floor, reading) in enumerate((f, r) for f in floors for r in readings):
        color, marker = FLOOR_STYLE.get(floor, ("tab:gray", "x"))
        vals = np.array([floor_value(fl, c, reading, floor)[:3] for (_, fl), c in zip(pairs, cells)])
        out.append({"v": vals[:, 0], "lo": vals[:, 1], "hi": vals[:, 2], "off": -0.2 + width * (k + 0.5),
                    "kw": {"marker": marker, "color": color, "mfc": color if reading == readings[0] else "white", "ms": 5,
                           "label": f"{FLOOR_TEXT.get(floor, floor)}, {reading}"}})
    return out, readings


@figure("figS5", "figS5_floors", paper=PAPER, section=SECTION, inputs=floors_inputs)
def fig_s5(*datasets: xr.Dataset):
    """The paper's AEKF-AR value, ours and the achievability floors per Table III cell."""
    pairs = pair_floors(datasets)
    cells = [str(r.attrs["scenario"]) for r, _ in pairs]
    x = np.arange(len(cells), dtype=float)
    fig, ax = new_figure(1, 1, figsize=(8.0, 4.8))
    series, readings = _series(pairs, cells)
    bottom = _bottom(series)
    for s in series:
        _errorbar(ax, x + s["off"], s["v"], s["lo"], s["hi"], bottom, **s["kw"])
    ax.set_yscale("log")
    ax.set_ylim(bottom=bottom)
    fl0, res0 = pairs[0][1], pairs[0][0]
    ax.set_xticks(x, [f"S$_4$ {float(fl['s4'].values[0]):g}\n$\\tau_0$ {float(fl['tau0'].values[0]):g} s" for _, fl in pairs])
    ax.set_xlim(-0.6, len(cells) - 0.4)
    ax.set_ylabel("steady-state $\\theta_d$ RMSE or floor [rad]")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, title=f"filled: {readings[0]}, open: {readings[-1]}", title_fontsize=7)
    ax.set_title(
        f"Table III AEKF-AR: paper, ours ({int(res0['n_trials'])} trials) and floors\n"
        f"synthetic CSM, C/N$_0$ = {float(fl0.attrs['cn0_dbhz']):g} dB-Hz; (b), (c) offset-corrected; floor intervals: "
        f"{int(fl0.attrs.get('groups', 0))} groups of {int(fl0.attrs.get('realisations', 0))} realisations", fontsize=8)
    fig.tight_layout()
    return fig
