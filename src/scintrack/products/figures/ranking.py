"""One figure ranking every tracker on every scenario (the cross-paper ranking).

Two heat maps: rows are trackers (best mean theta_d rank first), columns are
scenarios (grouped by integration time), the colour is the rank within the
scenario by the wrapped steady-state RMSE of theta_d (top; Vila-Valls's
metric) and of the total carrier phase (bottom; the receiver's view), and
each cell prints the RMSE.
Computed by :mod:`scintrack.products.tables.ranking` from the same results as
``table_ranking``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ...labels import tex
from ..registry import figure
from ..tables.ranking import PAPER, SECTION, UNIFORM_RMSE, ranking_inputs, ranking_long, ranking_summary, ranking_surrogate
from .common import new_figure

if TYPE_CHECKING:
    import xarray as xr


def _display_names(long) -> dict[str, str]:
    """Label per tracker, with the config name added where two trackers share a label."""
    labels = long.drop_duplicates("tracker").set_index("tracker")["label"]
    shared = labels[labels.duplicated(keep=False)].index
    return {tr: tex(lab) + (f" [{tr}]" if tr in shared else "") for tr, lab in labels.items()}


@figure("fig_ranking", "fig_ranking", paper=PAPER, section=SECTION, inputs=ranking_inputs, surrogate=ranking_surrogate)
def fig_ranking(*results: xr.Dataset):
    import pandas as pd
    from matplotlib import colormaps

    long = ranking_long(results)
    summary = ranking_summary(long)
    trackers = list(summary["tracker"])
    # columns: 1-ms scenarios first, then the others, each in their table order
    order = long.drop_duplicates("scenario")[["scenario", "ts_ms", "data"]]
    order = order.sort_values("ts_ms", kind="stable")
    scenarios = list(order["scenario"])
    rank = np.full((len(trackers), len(scenarios)), np.nan)
    rmse = np.full_like(rank, np.nan)
    n_of = np.full_like(rank, np.nan)
    rank_t = np.full_like(rank, np.nan)
    rmse_t = np.full_like(rank, np.nan)
    for r in long.itertuples():
        i, j = trackers.index(r.tracker), scenarios.index(r.scenario)
        rank[i, j] = np.nan if pd.isna(r.rank) else float(r.rank)
        rank_t[i, j] = np.nan if pd.isna(r.rank_total) else float(r.rank_total)
        rmse[i, j], rmse_t[i, j], n_of[i, j] = r.rmse_wrapped_rad, r.rmse_total_rad, r.n_trackers
    fig, axes = new_figure(2, 1, figsize=(0.8 * len(scenarios) + 4.6, 0.84 * len(trackers) + 4.4))
    cmap = colormaps["viridis_r"].with_extremes(bad="white")
    names = _display_names(long)
    ts = dict(zip(order["scenario"], order["ts_ms"]))
    data = dict(zip(order["scenario"], order["data"]))
    panels = ((axes[0], rank, rmse, summary["mean_rank"], "$\\theta_d$ (Vila-Valls's metric)"),
              (axes[1], rank_t, rmse_t, summary["mean_rank_total"], "total carrier phase $\\theta_d + \\theta_s$ (the receiver's view)"))
    for ax, rk, rm, mean_rank, what in panels:
        relative = (rk - 1) / np.maximum(n_of - 1, 1)
        im = ax.imshow(np.ma.masked_invalid(relative), cmap=cmap, vmin=0, vmax=1, aspect="auto")
        for i in range(len(trackers)):
            for j in range(len(scenarios)):
                if np.isfinite(rk[i, j]):
                    star = "*" if rm[i, j] >= 0.9 * UNIFORM_RMSE else ""
                    ax.text(j, i, f"{int(rk[i, j])}/{int(n_of[i, j])}\n{rm[i, j]:.2f}{star}", ha="center", va="center", fontsize=6,
                            color="w" if relative[i, j] > 0.5 else "k")
                else:
                    ax.text(j, i, "-", ha="center", va="center", fontsize=6, color="0.6")
        ax.set_yticks(range(len(trackers)))
        ax.set_yticklabels([f"{names[tr]} (mean rank {m:.1f})" for tr, m in zip(trackers, mean_rank)], fontsize=7)
        ax.set_xticks(range(len(scenarios)))
        ax.set_xticklabels([f"{sc}\n$T_s$ = {ts[sc]:g} ms" + ("\nSURROGATE" if data[sc] == "SURROGATE trace" else "") for sc in scenarios],
                           rotation=60, ha="right", fontsize=6.5)
        ax.grid(False)
        for j in range(1, len(scenarios)):
            if ts[scenarios[j]] != ts[scenarios[j - 1]]:
                ax.axvline(j - 0.5, color="tab:red", lw=2)
        cbar = fig.colorbar(im, ax=ax, fraction=0.04, pad=0.02)
        cbar.set_label("relative rank (0 = lowest RMSE)", fontsize=7)
        ax.set_title(f"rank by wrapped steady-state RMSE of the {what} (cell: rank / trackers, RMSE [rad])", fontsize=8)
    trials = sorted(long["trials"].unique())
    sur = "; Susi scenarios: SYNTHETIC SURROGATE traces" if (long["data"] == "SURROGATE trace").any() else ""
    fig.suptitle("All trackers on all scenarios\n"
                 f"red line: integration time changes; * RMSE near {UNIFORM_RMSE:.2f} rad (uniform wrapped error: the rank says little); "
                 f"{min(trials)}-{max(trials)} trials per cell (table_ranking){sur}", fontsize=8)
    fig.tight_layout()
    return fig
