"""One figure ranking every tracker on every scenario (the cross-paper ranking).

Two heat maps with the same rows and columns: rows are trackers, columns are
scenarios (grouped by integration time: the Susi trace scenarios at 1 ms, the
CSM scenarios at 10 ms).  The top panel is the wrapped steady-state RMSE of
theta_d (Vila-Valls's metric), the bottom one that of the total carrier phase
theta_d + theta_s (the receiver's view).  Choices a reader could question:

* **Colour is the error, not the rank**: one logarithmic colour scale for
  both panels, from the smallest RMSE drawn (rounded down to 1-2-5) to
  0.9 pi/sqrt(3) = 1.63 rad; a cell at or above it is red, "no lock"
  (pi/sqrt(3) = 1.81 rad is the RMSE of a wrapped error uniform on (-pi, pi]).
  Two trackers 0.89 and 0.92 rad apart get nearly the same colour; the rank
  within the scenario is printed in the cell beside the RMSE.
* **Uninformative columns are grey**: a scenario where every tracker is at the
  no-lock level for that metric
  (:func:`scintrack.products.tables.ranking.informative_scenarios`) is drawn
  grey with its RMSEs and without ranks, and counts in no mean rank.
* **Mean ranks** (the panel right of each heat map) are those of
  ``table_ranking_summary``, one definition
  (:func:`scintrack.products.tables.ranking.mean_rank_sets`): per integration
  time, over the informative scenarios every tracker of that Ts ran, so each
  mean averages the same scenarios and competitors; the header says how many.
  Rows are ordered by the theta_d mean rank of the Ts with the largest common
  set (the 10-ms CSM scenarios), then by the other Ts.
* **Outside the design** (:data:`~scintrack.products.tables.ranking.OUTSIDE_DESIGN`):
  a dagger marks a tracker run on dynamics it was not built for (Zhao's MM
  filter, a static-receiver clock model, on the CSM Doppler-rate ramp).
* **Labels**: trackers by the labels their results carry, with the AR design
  added where two configurations share a label (the AR model fitted at the
  scenario's S4, tau0, adaptive, or fitted on the trace); scenarios by
  :func:`scintrack.products.tables.ranking.scenario_label` from their config.

Computed by :mod:`scintrack.products.tables.ranking` from the same results as
``table_ranking``.  The figure has no counterpart in any of the three papers.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ...labels import tex
from ..registry import Verdict, figure
from ..tables.paper_values import TRACKERS_5, VILA_VALLS_2018_TABLE_III
from ..tables.ranking import (
    EXPERIMENTS,
    METRICS,
    NEAR_UNIFORM,
    OUTSIDE_DESIGN,
    PAPER,
    SECTION,
    mean_rank_sets,
    ranking_inputs,
    ranking_long,
    ranking_summary,
    ranking_surrogate,
    scenario_label,
)
from .common import new_figure
from .conventions import MIN_FONT_PT, NO_LOCK_RMSE_2PI, data_title, log_ticks

if TYPE_CHECKING:
    import pandas as pd
    import xarray as xr

DAGGER = "\u2020"
#: colour of a cell at the no-lock level
NO_LOCK_COLOUR = "#b2182b"
#: where a non-adaptive AR tracker's AR model comes from (the ``design`` key of its config), for labels that clash
AR_DESIGN_WORDS = {"scenario": "AR at true S4, tau0", "trace": "AR fit on trace", "none": "no AR model"}


def _ranking_kwargs(config: Mapping[str, Any]) -> dict[str, Any]:
    """The config entries of the ranked scenarios and trackers (for their labels)."""
    exps = [config["experiments"].get(e, {}) for e in EXPERIMENTS]
    scenarios = sorted({sc for e in exps for sc in e.get("scenarios", [])})
    trackers = sorted({tr for e in exps for tr in e.get("trackers", [])})
    return {"scenarios": {sc: dict(config["scenarios"].get(sc, {})) for sc in scenarios},
            "trackers": {tr: dict(config["trackers"].get(tr, {})) for tr in trackers}}


def display_names(long: pd.DataFrame, trackers: Mapping[str, Mapping[str, Any]] | None = None) -> dict[str, str]:
    """Label per tracker (mathtext); where two trackers share a label, the AR design (or the config name) is added."""
    labels = long.drop_duplicates("tracker").set_index("tracker")["label"]
    shared = set(labels[labels.duplicated(keep=False)].index)
    out = {}
    for tr, lab in labels.items():
        if tr in shared:
            spec = dict((trackers or {}).get(tr, {}))
            words = "adaptive" if spec.get("adaptive") else AR_DESIGN_WORDS.get(str(spec.get("design", "")), "")
            lab = f"{lab} ({words})" if words else f"{lab} [{tr}]"
        out[tr] = tex(lab).replace("tau0", "$\\tau_0$")
    return out


def _grid(long: pd.DataFrame, trackers: list[str], scenarios: list[str], column: str) -> np.ndarray:
    out = np.full((len(trackers), len(scenarios)), np.nan)
    for tr, sc, v in zip(long["tracker"], long["scenario"], long[column]):
        out[trackers.index(tr), scenarios.index(sc)] = np.nan if v is None or v != v else float(v)
    return out


def _floor_125(x: float) -> float:
    """The largest 1-2-5 value not above ``x``."""
    decade = 10.0 ** math.floor(math.log10(x))
    return max(m * decade for m in (1.0, 2.0, 5.0) if m * decade <= x * (1 + 1e-12))


def _data_words(long: pd.DataFrame) -> str:
    """``"Ts = 1 ms: <data words>; Ts = 10 ms: <data words>"`` (:func:`~.conventions.data_title`)."""
    word = {"synthetic CSM": "synthetic CSM", "SURROGATE trace": "surrogate", "real trace": "real"}
    groups = long.drop_duplicates(["ts_ms", "data"]).sort_values("ts_ms", kind="stable")
    return "; ".join(f"Ts = {ts:g} ms: {', '.join(data_title(word[d]) for d in g['data'])}" for ts, g in groups.groupby("ts_ms"))


def fig_ranking_verdict(*results: xr.Dataset, scenarios: Mapping[str, Any] | None = None,
                        trackers: Mapping[str, Any] | None = None) -> Verdict:
    """No paper has this figure: status "no paper figure" always.

    The line gives the best theta_d mean rank at each integration time (with the number of scenarios it
    averages), and checks Vila-Valls's Table III on the same grid: the paper's best tracker (the most frequent
    argmin of :data:`~scintrack.products.tables.paper_values.VILA_VALLS_2018_TABLE_III`) is compared with ours
    among the paper's five trackers on each Table III scenario, and its mean rank here is given.
    """
    long = ranking_long(results)
    summary = ranking_summary(long).set_index("tracker")
    parts = []
    for ts, scs in mean_rank_sets(long, "theta_d").items():
        col = f"mean_rank_{ts:g}ms"
        if not scs or summary[col].isna().all():
            continue
        best = summary[col].idxmin()
        parts.append(f"theta_d mean rank at {ts:g} ms over {len(scs)} scenario(s): {summary.loc[best, 'label']} {summary.loc[best, col]:.1f} best")
    paper_best = [TRACKERS_5[int(np.argmin(v))] for v in VILA_VALLS_2018_TABLE_III.values()]
    star = max(set(paper_best), key=paper_best.count)
    ours = n = 0
    for sc in VILA_VALLS_2018_TABLE_III:
        sub = long[(long["scenario"] == sc) & long["tracker"].isin(TRACKERS_5)]
        if len(sub) == len(TRACKERS_5):
            n += 1
            ours += sub.loc[sub["rmse_wrapped_rad"].idxmin(), "tracker"] == star
    if n and star in summary.index:
        label = summary.loc[star, "label"]
        rank = summary.loc[star, [c for c in summary.columns if c.startswith("mean_rank_") and "total" not in c]].dropna()
        parts.append(f"{label} lowest of Vila-Valls's five on {ours} of {n} Table III scenarios (paper: {paper_best.count(star)} of "
                     f"{len(paper_best)}), mean rank " + ", ".join(f"{v:.1f} at {c.rsplit('_', 1)[1].replace('ms', ' ms')}" for c, v in rank.items()))
    first = long.drop_duplicates("scenario")
    uninf = list(first.loc[~first["informative"].astype(bool), "scenario"])
    if uninf:
        low = float(long.loc[long["scenario"].isin(uninf), "rmse_wrapped_rad"].min())
        parts.append(f"theta_d uninformative on {', '.join(uninf)} (every tracker >= {low:.2f} rad)")
    return Verdict("no paper figure", "; ".join(parts))


@figure("fig_ranking", "fig_ranking", paper=PAPER, section=SECTION, inputs=ranking_inputs, surrogate=ranking_surrogate,
        kwargs=_ranking_kwargs, number=None,
        claim="No paper draws this: every tracker of the three papers on every scenario, ranked by steady-state phase RMSE",
        tables=("table_ranking",), verdict=fig_ranking_verdict)
def fig_ranking(*results: xr.Dataset, scenarios: Mapping[str, Mapping[str, Any]] | None = None,
                trackers: Mapping[str, Mapping[str, Any]] | None = None):
    from matplotlib import colormaps
    from matplotlib.colors import LogNorm

    long = ranking_long(results)
    summary = ranking_summary(long)
    rows = list(summary["tracker"])
    order = long.drop_duplicates("scenario")[["scenario", "ts_ms", "data", "cn0_dbhz", "duration_s"]].sort_values("ts_ms", kind="stable")
    cols = list(order["scenario"])
    ts_of = dict(zip(order["scenario"], order["ts_ms"]))
    names = display_names(long, trackers)
    outside = _grid(long.assign(o=long["outside_design"].astype(float)), rows, cols, "o") > 0
    xlabels = [tex(scenario_label(sc, (scenarios or {}).get(sc), ts_ms=r.ts_ms, cn0_dbhz=r.cn0_dbhz, duration_s=r.duration_s,
                                  data=r.data, sep="\n")).replace("tau0", "$\\tau_0$")
               for sc, r in zip(cols, order.itertuples())]

    rmse_all = long[["rmse_wrapped_rad", "rmse_total_rad"]].to_numpy(dtype=float)
    no_lock = NEAR_UNIFORM * NO_LOCK_RMSE_2PI
    norm = LogNorm(vmin=_floor_125(float(np.nanmin(rmse_all[rmse_all > 0]))), vmax=no_lock)
    cmap = colormaps["viridis_r"].with_extremes(bad="white", over=NO_LOCK_COLOUR)
    ts_groups = sorted({float(t) for t in order["ts_ms"]})

    n_r, n_c = len(rows), len(cols)
    cell_w, cell_h = 0.66, 0.27
    left_in = 0.25 + max(len(lab) for lab in (names[tr] for tr in rows)) * 0.5 * 8 / 72
    fig_w = max(left_in + cell_w * n_c + 0.62 * len(ts_groups) + 1.25, left_in + 8.3)  # the panel titles fit
    fig_h = 2 * (cell_h * n_r + 1.45) + 1.5
    fig, _ = new_figure(1, 1, figsize=(fig_w, fig_h))
    fig.clf()
    side_in, cbar_in = 0.62 * len(ts_groups), 0.25
    heat_in = fig_w - left_in - 0.8 - side_in - cbar_in - 0.25  # the heat map takes any width the titles added
    gs = fig.add_gridspec(2, 3, width_ratios=[heat_in, side_in, cbar_in], wspace=0.04, hspace=0.55)
    panels = (("theta_d", "Error on $\\theta_d$ (Vila-Valls's metric)"),
              ("total", "Error on the total phase $\\theta_d + \\theta_s$ (the receiver's view)"))
    im = None
    for p, (metric, what) in enumerate(panels):
        rmse_col, rank_col = METRICS[metric]
        sfx = "" if metric == "theta_d" else "_total"
        rm = _grid(long, rows, cols, rmse_col)
        rk = _grid(long, rows, cols, rank_col)
        informative = long.drop_duplicates("scenario").set_index("scenario")["informative" + sfx].reindex(cols).to_numpy(bool)
        ax = fig.add_subplot(gs[p, 0])
        shown = np.where(informative[None, :], rm, np.nan)
        im = ax.imshow(np.ma.masked_invalid(shown), cmap=cmap, norm=norm, aspect="auto", interpolation="nearest")
        for j in np.flatnonzero(~informative):
            ax.axvspan(j - 0.5, j + 0.5, color="0.86", lw=0, zorder=0.5)
        for i in range(n_r):
            for j in range(n_c):
                if not np.isfinite(rm[i, j]):
                    ax.text(j, i, "not run", ha="center", va="center", fontsize=MIN_FONT_PT, color="0.6")
                    continue
                mark = DAGGER if outside[i, j] else ""
                if informative[j]:
                    dark = norm(rm[i, j]) > 0.55
                    ax.text(j, i, f"{rm[i, j]:.2f}{mark} ({int(rk[i, j])})", ha="center", va="center", fontsize=MIN_FONT_PT,
                            color="w" if dark else "k")
                else:
                    ax.text(j, i, f"{rm[i, j]:.2f}{mark}", ha="center", va="center", fontsize=MIN_FONT_PT, color="0.3")
        ax.set_yticks(range(n_r))
        ax.set_yticklabels([names[tr] for tr in rows], fontsize=8)
        ax.set_xticks(range(n_c))
        common = {sc for scs in mean_rank_sets(long, metric).values() for sc in scs}
        labels_p = [lab + ("\n(not in mean)" if inf and sc not in common else "") for lab, sc, inf in zip(xlabels, cols, informative)]
        ax.set_xticklabels(labels_p, rotation=35, ha="right", rotation_mode="anchor", fontsize=MIN_FONT_PT)
        ax.grid(False)
        ax.tick_params(length=0)
        for j in range(1, n_c):
            if ts_of[cols[j]] != ts_of[cols[j - 1]]:
                ax.axvline(j - 0.5, color="k", lw=2.0)
        ax.set_title(f"{what}: wrapped steady-state RMSE [rad] (rank in the scenario)", fontsize=9, loc="left")

        # mean ranks: the summary's columns, with the number of scenarios each averages
        side = fig.add_subplot(gs[p, 1], sharey=ax)
        sets = mean_rank_sets(long, metric)
        for k, ts in enumerate(ts_groups):
            for i, tr in enumerate(rows):
                v = float(summary.set_index("tracker").loc[tr, f"mean_rank{sfx}_{ts:g}ms"])
                side.text(k, i, f"{v:.1f}" if np.isfinite(v) else "-", ha="center", va="center", fontsize=8,
                          color="k" if np.isfinite(v) else "0.6")
        side.set_xlim(-0.5, len(ts_groups) - 0.5)
        side.set_xticks(range(len(ts_groups)))
        side.set_xticklabels([f"{ts:g} ms\n({len(sets[ts])} scen.)" for ts in ts_groups], fontsize=MIN_FONT_PT)
        side.set_title("mean rank", fontsize=8)
        side.yaxis.set_visible(False)
        side.grid(False)
        side.tick_params(length=0)
        for spine in side.spines.values():
            spine.set_color("0.7")
        ax.set_ylim(n_r - 0.5, -0.5)

    cax = fig.add_subplot(gs[:, 2])
    cbar = fig.colorbar(im, cax=cax, extend="max", extendfrac=0.06)
    log_ticks(cax, "y")
    cbar.ax.tick_params(labelsize=MIN_FONT_PT + 1)
    cax.xaxis.set_visible(False)
    cbar.set_label(f"steady-state RMSE [rad] (red: $\\geq$ {no_lock:.2f} = {NEAR_UNIFORM:g} $\\pi/\\sqrt{{3}}$, no lock)", fontsize=8)

    trials = sorted(long["trials"].unique())
    sets_d = mean_rank_sets(long, "theta_d")
    row_ts = max(sets_d, key=lambda t: len(sets_d[t]))
    caption = (
        f"Colour: RMSE on one log scale for both panels; red: at or above {NEAR_UNIFORM:g} $\\pi/\\sqrt{{3}}$ = {no_lock:.2f} rad, "
        "no lock ($\\pi/\\sqrt{3}$: RMSE of a wrapped error uniform on $(-\\pi, \\pi]$). Grey column: every tracker there (uninformative): "
        "not ranked, in no mean. Mean rank: per integration time, over the informative scenarios every tracker of that Ts ran "
        f"(number in the header; other columns say 'not in mean'); rows by the {row_ts:g}-ms $\\theta_d$ mean rank. "
        + (f"{DAGGER} {_outside_caption(long)} " if long["outside_design"].any() else "")
        + f"{min(trials)}-{max(trials)} trials per cell (table_ranking)."
    )
    chars = int(fig_w * 72 / (0.5 * MIN_FONT_PT)) - 4
    wrapped = textwrap.fill(caption, chars)
    fig.suptitle(textwrap.fill("All trackers on all scenarios. " + _data_words(long), int(fig_w * 72 / (0.55 * 10))), fontsize=10)
    n_lines = wrapped.count("\n") + 1
    bottom_in = (n_lines * 1.3 * MIN_FONT_PT + 8) / 72
    fig.text(0.01, 0.004, wrapped, ha="left", va="bottom", fontsize=MIN_FONT_PT)
    fig.subplots_adjust(left=left_in / fig_w, right=1 - 0.8 / fig_w, top=1 - 0.75 / fig_h, bottom=(bottom_in + 1.2) / fig_h)
    return fig


def _outside_caption(long: pd.DataFrame) -> str:
    parts = []
    for tr, (data, why) in OUTSIDE_DESIGN.items():
        hit = long[(long["tracker"] == tr) & long["outside_design"]]
        if len(hit):
            parts.append(f"{why} (its {len(hit)} {data} cells; it stays in the ranking).")
    return " ".join(parts)
