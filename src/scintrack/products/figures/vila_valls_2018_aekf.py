"""Vila-Valls et al. 2018, Table III: the AEKF-AR question, figures.

``figS5``: per Table III cell, the paper's AEKF-AR value, ours (95% interval
over trials) and the achievability floors of both readings with their
intervals, on a log axis (the numbers of ``tableS5_floors``).

Choices a reader could question, each also said on the figure:

* The floors bound the error of theta_d itself (unwrapped: in reading R1 at
  S4 >= 0.7 they reach 3-20 rad), whereas the paper's and our RMSEs are of
  the error wrapped to (-pi, pi], which cannot exceed pi/sqrt(3) = 1.81 rad
  (:func:`~.conventions.no_lock_level`, drawn).  A floor above 1.81 rad
  says that no estimator keeps theta_d within a cycle under that model, i.e.
  its wrapped error is that of no lock; it is not a number the wrapped RMSE
  should reach.
* GLS floors (b), (c) are offset-corrected: sqrt(floor^2 + variance of the
  per-run mean of theta_s), because a constant phase offset cannot be told
  from the polynomial's constant and adds in full to any estimator's error.
* A floor that does not exist (no valid steady-state DARE: the linearised
  model is not detectable when the phase AR has a unit root) is drawn as an
  open cross at the bottom of the axis, labelled "no DARE".
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..registry import Verdict, figure
from ..tables.vila_valls_2018_aekf import FLOOR_TEXT, PAPER, SECTION, floor_value, floors_inputs, pair_floors, paper_rmse, steady
from .common import new_figure
from .conventions import NO_LOCK_RMSE_2PI, data_title, legend_outside, log_ticks, no_lock_level

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


def fig_s5_verdict(*datasets: xr.Dataset) -> Verdict:
    """No paper figure.  The line counts the Table III cells whose paper AEKF-AR value lies below the lowest
    lower 95% limit (or the value, without an interval) of every floor of reading R1 (not achievable under
    any floor), from the same numbers as ``tableS5_floors``."""
    pairs = pair_floors(datasets)
    below, parts = 0, []
    for res, fl in pairs:
        cell = str(res.attrs["scenario"])
        paper = paper_rmse(cell, "aekf_ar")
        reading = str(fl["reading"].values[0])
        lows = []
        for floor in map(str, fl["floor"].values):
            v, lo, _hi, _ = floor_value(fl, cell, reading, floor)
            if np.isfinite(v):
                lows.append(lo if np.isfinite(lo) else v)
        lowest = min(lows) if lows else float("nan")
        below += bool(np.isfinite(lowest) and paper < lowest)
        parts.append(f"S4 {float(fl['s4'].values[0]):g}: paper {paper:.2f} vs lowest floor {lowest:.3g}")
    return Verdict("no paper figure", f"paper AEKF-AR below every {reading} floor in {below} of {len(pairs)} cells; " + "; ".join(parts) + " rad")


@figure("figS5", "figS5_floors", paper=PAPER, section=SECTION, inputs=floors_inputs, number=None, tables=("tableS5",),
        claim="Not in the paper: whether the paper's AEKF-AR RMSE lies above the lowest theta_d error any estimator can reach in each Table III cell",
        verdict=fig_s5_verdict)
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
    missing = _mark_missing(ax, x, series, bottom)
    no_lock_level(ax, NO_LOCK_RMSE_2PI, label="wrapped RMSE without lock: $\\pi/\\sqrt{3}$ = 1.81 rad")
    top = max(ax.get_ylim()[1], NO_LOCK_RMSE_2PI * 2)
    ax.set_ylim(bottom, top)
    log_ticks(ax, "y")
    fl0, res0 = pairs[0][1], pairs[0][0]
    ax.set_xticks(x, [f"S$_4$ {float(fl['s4'].values[0]):g}\n$\\tau_0$ {float(fl['tau0'].values[0]):g} s" for _, fl in pairs])
    ax.set_xlim(-0.6, len(cells) - 0.4)
    ax.set_ylabel("steady-state $\\theta_d$ RMSE or floor [rad]")
    legend_outside(ax, "right", fontsize=7, title=f"filled: {readings[0]}, open: {readings[-1]}", title_fontsize=7)
    ax.set_title(
        f"Table III AEKF-AR: paper, ours ({int(res0['n_trials'])} trials) and achievability floors\n"
        f"{data_title('synthetic CSM')}, C/N$_0$ = {float(fl0.attrs['cn0_dbhz']):g} dB-Hz; floor intervals: "
        f"{int(fl0.attrs.get('groups', 0))} groups of {int(fl0.attrs.get('realisations', 0))} realisations", fontsize=8)
    notes = [
        "Floors bound the error of theta_d itself (unwrapped; up to 20 rad in R1 at S4 >= 0.7); the paper's and our RMSEs are of the "
        "error wrapped to (-pi, pi], at most pi/sqrt(3) = 1.81 rad (dashed). A floor above that line means no estimator keeps theta_d "
        "within a cycle: different quantities, not a level the wrapped RMSE should reach.",
        "(b), (c) offset-corrected: sqrt(floor^2 + variance of the per-run mean of theta_s); a constant phase offset cannot be told "
        "from the dynamics' constant and adds in full to any estimator's error.",
    ]
    if missing:
        notes.append(f"x at the bottom, for {missing}: no floor, no valid steady-state DARE (the linearised model is not detectable: "
                     "the phase AR has a unit root, theta_d and theta_s enter only as their sum).")
    import textwrap

    fig.text(0.01, 0.005, "\n".join(textwrap.fill(n, 135) for n in notes), fontsize=7, ha="left", va="bottom")
    fig.tight_layout(rect=(0, 0.02 + 0.028 * sum(len(textwrap.wrap(n, 135)) for n in notes), 1, 1))
    return fig


def _mark_missing(ax, x, series, bottom) -> str:
    """An open cross at the axis bottom for every floor without a value; returns the cells' labels."""
    cells = []
    for s in series:
        v = np.asarray(s["v"], float)
        gone = ~np.isfinite(v)
        if not gone.any() or s["kw"].get("label", "").startswith("paper"):
            continue
        ax.plot((x + s["off"])[gone], np.full(gone.sum(), bottom * 1.15), ls="none", marker="x", ms=6, mew=1.2, color=s["kw"]["color"])
        for xi in (x + s["off"])[gone]:
            ax.annotate("no DARE", xy=(xi, bottom * 1.15), xytext=(0, 5), textcoords="offset points", rotation=90, fontsize=7,
                        ha="center", va="bottom", color=s["kw"]["color"])
        cells.append(f"{s['kw']['label']}")
    return "; ".join(dict.fromkeys(cells))
