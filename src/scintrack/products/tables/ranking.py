"""Every tracker on every scenario: one ranking across the three papers.

Reads the results of the experiments in :data:`EXPERIMENTS` (the scenarios of
each from the config) and ranks, within each scenario, every tracker that ran
on it by its wrapped steady-state RMSE of theta_d (Vila-Valls 2018's
metric), and separately by the wrapped steady-state RMSE of its *total*
carrier phase against theta_d + theta_s (the receiver's view, Susi et al.'s:
a loop that follows the scintillation is right to; see
:mod:`scintrack.experiments.runner`).  A tracker that ran on one scenario in two experiments (e.g. the PLL
in ``case2_steady_state`` and ``cross_mm_csm``) keeps the run with more
trials; experiments that share a scenario see the same realisations per
trial (:mod:`scintrack.experiments.scenario`), so the runs differ only in
their number of trials.

The Susi scenarios run at Ts = 1 ms, the CSM scenarios at 10 ms; the table
says so per row and the summary gives the mean rank per integration time as
well as overall.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from ...experiments.metrics import mean_with_ci
from ...labels import tracker_labels
from ...pipeline import paths
from ..registry import table
from .susi_2014 import any_surrogate, experiment_scenarios

if TYPE_CHECKING:
    import xarray as xr

PAPER = "cross_paper"
SECTION = "All trackers on all scenarios"
UNIFORM_RMSE = float(np.pi / np.sqrt(3))  # RMSE of a wrapped error uniform on (-pi, pi]: no tracking information left
EXPERIMENTS = ("susi_chapter", "susi_cross", "susi_on_csm", "case2_steady_state", "cycle_slips", "cross_mm_csm")


def ranking_inputs(config: Mapping[str, Any]) -> dict[str, str]:
    return {f"{e}__{sc}": paths.exp_result(e, sc) for e in EXPERIMENTS for sc in experiment_scenarios(config, e)}


def ranking_surrogate(config: Mapping[str, Any]) -> bool:
    """True unless every trace scenario used is real (the high-latitude one never is)."""
    return any_surrogate(config, sorted({sc for e in EXPERIMENTS for sc in experiment_scenarios(config, e)}))


def duration_s(ds: xr.Dataset) -> float:
    """Length of the run: the time grid is of block means, spaced by the block length."""
    t = np.asarray(ds["time"].values, dtype=float)
    block = int(ds.attrs.get("stats_block_epochs", 0)) or int(round((t[1] - t[0]) / float(ds.attrs["ts"])))
    return t.size * block * float(ds.attrs["ts"])


def _rank_rows(results: Sequence[xr.Dataset]) -> list[dict]:
    rows = []
    for order, res in enumerate(results):
        label = tracker_labels(res)
        minutes = duration_s(res) / 60.0
        for tr in res["tracker"].values:
            tr = str(tr)
            st = res.sel(tracker=tr, kind="wrapped")
            m, lo, hi = mean_with_ci(res["slip_events"].sel(tracker=tr).values / minutes)
            mt, lot, hit = mean_with_ci(res["slip_events_total"].sel(tracker=tr).values / minutes)
            rows.append({
                "scenario": res.attrs["scenario"], "ts_ms": float(res.attrs["ts"]) * 1000, "data": _data(res), "tracker": tr,
                "label": label.get(tr, tr), "experiment": res.attrs.get("experiment", ""), "trials": int(res["n_trials"]),
                "rmse_wrapped_rad": float(st["steady_rmse"]), "ci95_lo": float(st["steady_rmse_lo"]), "ci95_hi": float(st["steady_rmse_hi"]),
                "slip_events_per_min": float(m), "slips_ci95_lo": float(lo), "slips_ci95_hi": float(hi),
                "rmse_total_rad": float(res["steady_rmse_total"].sel(tracker=tr)), "total_ci95_lo": float(res["steady_rmse_total_lo"].sel(tracker=tr)),
                "total_ci95_hi": float(res["steady_rmse_total_hi"].sel(tracker=tr)), "total_slip_events_per_min": float(mt),
                "total_slips_ci95_lo": float(lot), "total_slips_ci95_hi": float(hit), "_order": order,
            })
    return rows


def _data(res: xr.Dataset) -> str:
    src = res.attrs.get("trace_source")
    if src is None:
        return "synthetic CSM"
    return "real trace" if src == "real" else "SURROGATE trace"


def ranking_long(results: Sequence[xr.Dataset]) -> pd.DataFrame:
    """One row per (scenario, tracker), duplicates resolved, ranked by RMSE within each scenario."""
    df = pd.DataFrame(_rank_rows(results))
    df["_pos"] = np.arange(len(df))
    # more trials first, then the experiment listed first; keep one row per (scenario, tracker)
    ordered = df.sort_values(["scenario", "tracker", "trials", "_order"], ascending=[True, True, False, True], kind="stable")
    also = {}
    for key, g in ordered.groupby(["scenario", "tracker"], sort=False):
        also[key] = "; ".join(f"{e} ({n} trials)" for e, n in zip(g["experiment"].iloc[1:], g["trials"].iloc[1:]))
    kept = ordered.drop_duplicates(["scenario", "tracker"], keep="first").copy()
    kept["dropped_duplicate"] = [also.get((s, t), "") for s, t in zip(kept["scenario"], kept["tracker"])]
    scen_order = {s: i for i, s in enumerate(dict.fromkeys(df["scenario"]))}
    kept["_scen"] = kept["scenario"].map(scen_order)
    kept["rank"] = kept.groupby("scenario")["rmse_wrapped_rad"].rank(method="min").astype("Int64")
    kept["rank_total"] = kept.groupby("scenario")["rmse_total_rad"].rank(method="min").astype("Int64")
    kept["n_trackers"] = kept.groupby("scenario")["tracker"].transform("size")
    best_hi = kept.loc[kept["rank"].eq(1).fillna(False).astype(bool)].groupby("scenario")["ci95_hi"].min()
    kept["ci_overlaps_best"] = kept["ci95_lo"] <= kept["scenario"].map(best_hi)
    kept["near_uniform"] = kept["rmse_wrapped_rad"] >= 0.9 * UNIFORM_RMSE
    kept = kept.sort_values(["_scen", "rank", "_pos"], kind="stable")
    cols = ["scenario", "ts_ms", "data", "rank", "n_trackers", "tracker", "label", "rmse_wrapped_rad", "ci95_lo", "ci95_hi", "ci_overlaps_best",
            "near_uniform", "slip_events_per_min", "slips_ci95_lo", "slips_ci95_hi", "rank_total", "rmse_total_rad", "total_ci95_lo",
            "total_ci95_hi", "total_slip_events_per_min", "total_slips_ci95_lo", "total_slips_ci95_hi", "trials", "experiment", "dropped_duplicate"]
    return kept[cols].reset_index(drop=True)


def ranking_summary(long: pd.DataFrame) -> pd.DataFrame:
    """Mean rank per tracker over the scenarios it ran (overall and per Ts), best first."""
    rel = (long["rank"].astype(float) - 1) / (long["n_trackers"] - 1).clip(lower=1)
    long = long.assign(relative_rank=rel)
    rows = []
    for tr, g in long.groupby("tracker", sort=False):
        row = {"tracker": tr, "label": g["label"].iloc[0], "scenarios": len(g), "mean_rank": float(g["rank"].astype(float).mean()),
               "mean_relative_rank": float(g["relative_rank"].mean()), "times_rank_1": int((g["rank"] == 1).sum()),
               "mean_rank_total": float(g["rank_total"].astype(float).mean()), "times_rank_1_total": int((g["rank_total"] == 1).sum())}
        for ts in sorted(long["ts_ms"].unique()):
            sub = g[g["ts_ms"] == ts]
            row[f"mean_rank_{ts:g}ms"] = float(sub["rank"].astype(float).mean()) if len(sub) else np.nan
            row[f"scenarios_{ts:g}ms"] = len(sub)
        row["trials"] = ", ".join(str(n) for n in sorted(g["trials"].unique()))
        rows.append(row)
    return pd.DataFrame(rows).sort_values(["mean_rank", "mean_relative_rank"], kind="stable").reset_index(drop=True)


def trial_note(long: pd.DataFrame) -> str:
    parts = []
    for tr, g in long.groupby("tracker", sort=False):
        counts = ", ".join(f"{n} ({k} scenario{'s' if k > 1 else ''})" for n, k in g.groupby("trials").size().items())
        parts.append(f"{g['label'].iloc[0]} [{tr}] {counts}")
    return "Trials per cell: " + "; ".join(parts) + "."


def ts_note(long: pd.DataFrame) -> str:
    first = long.drop_duplicates("scenario")
    return "; ".join(f"{ts:g} ms: {', '.join(g['scenario'])}" for ts, g in first.groupby("ts_ms", sort=True))


def ranking_note(long: pd.DataFrame, results: Sequence[xr.Dataset]) -> str:
    ts = ts_note(long)
    src = sorted({f"{r.attrs['scenario']} ({r.attrs.get('trace_source')})" for r in results if r.attrs.get("trace_source")})
    starts = sorted({float(r.attrs["steady_state_start_s"]) for r in results})
    return (
        "Metric: Vila-Valls 2018's wrapped steady-state RMSE of theta_d (the error against the dynamics phase, from "
        f"{' / '.join(f'{s:g}' for s in starts)} s to the end; 95% interval over trials), so a tracker that follows the scintillation phase "
        "is penalised for it; the Susi trackers' own metric is the phase jitter (tables/susi_2014/table_jitter). Slip events per minute are "
        "counted on the same error over the whole run. rank_total / rmse_total / total_slip_events: the same for the error of the "
        "tracker's total carrier-phase estimate against theta_d + theta_s (what a receiver's carrier phase delivers; the AR trackers' "
        "theta_d + theta_s estimate, every other tracker's own phase). Rank 1 = lowest RMSE within the scenario (ties share the lower rank); "
        "ci_overlaps_best: the 95% interval reaches the rank-1 tracker's; near_uniform: RMSE within 10% of pi/sqrt(3) = "
        f"{UNIFORM_RMSE:.3g} rad, the RMSE of a uniformly distributed wrapped error (lock on theta_d lost, or a scintillation phase "
        "beyond +-pi), where the rank says little. A tracker run on one scenario in two experiments keeps the run with "
        "more trials (dropped_duplicate names the other). Integration times differ (" + ts + "); the summary gives mean ranks per Ts. "
        + trial_note(long) + (" Trace scenarios: " + ", ".join(src) + " (surrogate = synthetic phase screen, not recorded data); every trial "
                              "there sees the same trace, so their intervals cover noise realisations only." if src else "")
    )


@table("table_ranking", ["table_ranking", "table_ranking_summary"], paper=PAPER, section=SECTION, inputs=ranking_inputs, surrogate=ranking_surrogate)
def table_ranking(*results: xr.Dataset) -> dict:
    """Every tracker on every scenario, ranked by theta_d steady-state RMSE, and the mean rank per tracker."""
    long = ranking_long(results)
    note = ranking_note(long, results)
    sur = " (includes SURROGATE data)" if any(r.attrs.get("trace_source") == "surrogate" for r in results) else ""
    return {
        "table_ranking": (long, f"All trackers on all scenarios: wrapped theta_d steady-state RMSE and rank{sur}", note),
        "table_ranking_summary": (ranking_summary(long), f"All trackers on all scenarios: mean rank per tracker{sur}", note),
    }
