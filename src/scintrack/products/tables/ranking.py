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

Which ranks count (:func:`mean_rank_sets`, used by the table's summary and by
the figure ``fig_ranking`` alike):

* a scenario is *uninformative* for a metric when every tracker's RMSE on it
  is at least :data:`NEAR_UNIFORM` times pi/sqrt(3), the RMSE of a wrapped
  error uniform on (-pi, pi]: no tracker holds lock on that phase, and the
  order among them is noise around the no-lock level;
* the mean rank is taken per integration time (the Susi scenarios run at
  Ts = 1 ms on traces, the CSM scenarios at 10 ms), over the *common set*:
  the informative scenarios of that Ts on which every tracker that ran at
  that Ts ran.  Every mean therefore averages the same scenarios with the
  same competitors; a scenario outside the set (e.g. a cycle-slip case the MM
  filter did not run) is ranked in the long table and left out of the mean.
  There is no mean over both integration times: no tracker set covers both
  (the AR trackers differ by where their AR model comes from).

:data:`OUTSIDE_DESIGN` names the trackers that run on dynamics they were not
designed for (the MM filter on the CSM scenarios); their cells are flagged
(``outside_design``) and stay in the ranking.
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
from .common import NO_INTERVAL
from .susi_2014 import any_surrogate, experiment_scenarios

if TYPE_CHECKING:
    import xarray as xr

PAPER = "cross_paper"
SECTION = "All trackers on all scenarios"
UNIFORM_RMSE = float(np.pi / np.sqrt(3))  # RMSE of a wrapped error uniform on (-pi, pi]: no tracking information left
#: an RMSE at or above this share of :data:`UNIFORM_RMSE` counts as "no lock" (near_uniform)
NEAR_UNIFORM = 0.9
#: the two rankings: metric -> (RMSE column, rank column) of :func:`ranking_long`
METRICS = {"theta_d": ("rmse_wrapped_rad", "rank"), "total": ("rmse_total_rad", "rank_total")}
#: trackers run on dynamics outside their design: tracker -> (data it is outside its design on, why)
OUTSIDE_DESIGN = {
    "zhao_mm": ("synthetic CSM", "Zhao's MM filter models a static receiver's clock (phase and a random-walk frequency, "
                "no Doppler-rate state); the CSM scenarios' Doppler-rate ramp is outside its design"),
}
EXPERIMENTS = ("susi_chapter", "susi_cross", "susi_on_csm", "case2_steady_state", "cycle_slips", "cross_mm_csm")


def ranking_inputs(config: Mapping[str, Any]) -> dict[str, str]:
    return {f"{e}__{sc}": paths.exp_result(e, sc) for e in EXPERIMENTS for sc in experiment_scenarios(config, e)}


def ranking_surrogate(config: Mapping[str, Any]) -> bool:
    """True unless every trace scenario used is real (the high-latitude one never is)."""
    return any_surrogate(config, sorted({sc for e in EXPERIMENTS for sc in experiment_scenarios(config, e)}))


def scenario_label(name: str, spec: Mapping[str, Any] | None = None, *, ts_ms: float | None = None, cn0_dbhz: float | None = None,
                   duration_s: float | None = None, data: str | None = None, sep: str = ", ") -> str:
    """A scenario as a reader names it, from its config entry ``spec`` and the run's Ts, C/N0 and length.

    CSM: ``"S4 0.9, tau0 0.1 s, 10 ms, 30 dB-Hz"`` (a run longer than a minute adds its length, e.g. the
    500-s cycle-slip cases; a scenario whose S4 changes lists every segment); trace scenarios: the trace's name
    and whether it is a SURROGATE or a real recording.  Without ``spec`` the config name stands in for the
    scintillation part.  ``sep`` joins the parts (``"\n"``: one part per line).
    """
    spec = dict(spec or {})
    parts = []
    trace = (spec.get("trace") or {}).get("name")
    segments = spec.get("segments") or []
    if trace:
        parts.append(f"{str(trace).replace('_', '-')} trace")
        if data:
            parts.append("SURROGATE" if "SURROGATE" in data else data)
    elif segments:
        parts.append(" then ".join(f"S4 {float(g['s4']):g}, tau0 {float(g['tau0']):g} s" for g in segments))
    else:
        parts.append(name)
    run = []
    if ts_ms is not None:
        run.append(f"{ts_ms:g} ms")
    if cn0_dbhz is not None and np.isfinite(cn0_dbhz):
        run.append(f"{cn0_dbhz:g} dB-Hz")
    length = duration_s if duration_s is not None else spec.get("duration_s")
    if length is not None and float(length) > 60.0 + 1e-9 and not trace:
        run.append(f"{float(length):g} s")
    if run:
        parts.append(", ".join(run))
    return sep.join(parts)


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
                "cn0_dbhz": float(res.attrs.get("cn0_dbhz", np.nan)), "duration_s": duration_s(res),
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
    kept["ci_overlaps_best"] = overlaps(kept["ci95_lo"], kept["scenario"].map(best_hi))
    kept["near_uniform"] = kept["rmse_wrapped_rad"] >= NEAR_UNIFORM * UNIFORM_RMSE
    kept["outside_design"] = [OUTSIDE_DESIGN.get(t, ("", ""))[0] == d for t, d in zip(kept["tracker"], kept["data"])]
    kept = kept.sort_values(["_scen", "rank", "_pos"], kind="stable")
    for metric, (rmse_col, _rank_col) in METRICS.items():
        sfx = "" if metric == "theta_d" else "_total"
        kept["informative" + sfx] = kept["scenario"].map(informative_scenarios(kept, rmse_col))
        common = {sc for scs in mean_rank_sets(kept, metric).values() for sc in scs}
        kept["in_mean_rank" + sfx] = kept["scenario"].isin(common)
    cols = ["scenario", "ts_ms", "data", "cn0_dbhz", "duration_s", "rank", "n_trackers", "tracker", "label", "rmse_wrapped_rad", "ci95_lo",
            "ci95_hi", "ci_overlaps_best", "near_uniform", "informative", "in_mean_rank", "outside_design", "slip_events_per_min",
            "slips_ci95_lo", "slips_ci95_hi", "rank_total", "rmse_total_rad", "total_ci95_lo", "total_ci95_hi", "informative_total",
            "in_mean_rank_total", "total_slip_events_per_min", "total_slips_ci95_lo", "total_slips_ci95_hi", "trials", "experiment",
            "dropped_duplicate"]
    return kept[cols].reset_index(drop=True)


def overlaps(lo: pd.Series, best_hi: pd.Series) -> pd.Series:
    """Whether each interval reaches the rank-1 tracker's (``lo <= best_hi``); missing (<NA>) where either has no
    interval (one trial), since no overlap can be stated then.  Plain booleans when every interval exists."""
    out = lo <= best_hi
    unknown = lo.isna() | best_hi.isna()
    return out.astype("boolean").mask(unknown) if unknown.any() else out


def informative_scenarios(long: pd.DataFrame, rmse_col: str = "rmse_wrapped_rad") -> dict[str, bool]:
    """Scenario -> whether some tracker's RMSE (``rmse_col``) is below the no-lock level (NEAR_UNIFORM x pi/sqrt(3))."""
    return {sc: bool((g[rmse_col] < NEAR_UNIFORM * UNIFORM_RMSE).any()) for sc, g in long.groupby("scenario", sort=False)}


def mean_rank_sets(long: pd.DataFrame, metric: str = "theta_d") -> dict[float, list[str]]:
    """Ts [ms] -> the common scenario set the mean ``metric`` rank at that Ts averages (module docstring).

    The informative scenarios of that Ts on which every tracker that ran on any of them ran, in table order.
    """
    rmse_col, _ = METRICS[metric]
    informative = informative_scenarios(long, rmse_col)
    out = {}
    for ts in sorted(long["ts_ms"].unique()):
        sub = long[(long["ts_ms"] == ts) & long["scenario"].map(informative)]
        trackers = set(sub["tracker"])
        out[float(ts)] = [sc for sc, g in sub.groupby("scenario", sort=False) if set(g["tracker"]) == trackers]
    return out


def ranking_summary(long: pd.DataFrame) -> pd.DataFrame:
    """Mean rank per tracker and Ts over the common scenario sets (:func:`mean_rank_sets`), in the order of the Ts
    with the largest theta_d set first (then the other Ts; trackers without a mean rank last)."""
    sets = {m: mean_rank_sets(long, m) for m in METRICS}
    informative = {m: informative_scenarios(long, METRICS[m][0]) for m in METRICS}
    rows = []
    for tr, g in long.groupby("tracker", sort=False):
        row = {"tracker": tr, "label": g["label"].iloc[0], "scenarios": len(g)}
        for metric, (_rmse_col, rank_col) in METRICS.items():
            sfx = "" if metric == "theta_d" else "_total"
            for ts, scs in sets[metric].items():
                sub = g[g["scenario"].isin(scs)]
                row[f"mean_rank{sfx}_{ts:g}ms"] = float(sub[rank_col].astype(float).mean()) if len(sub) else np.nan
                row[f"scenarios_in_mean{sfx}_{ts:g}ms"] = len(sub)
            inf = g[g["scenario"].map(informative[metric])]
            row["times_rank_1" + sfx] = int((inf[rank_col] == 1).sum())
        row["uninformative_scenarios"] = int((~g["scenario"].map(informative["theta_d"])).sum())
        row["outside_design_scenarios"] = int(g["outside_design"].sum()) if "outside_design" in g else 0
        row["trials"] = ", ".join(str(n) for n in sorted(g["trials"].unique()))
        rows.append(row)
    ts_order = sorted(sets["theta_d"], key=lambda ts: -len(sets["theta_d"][ts]))
    keys = [f"mean_rank_{ts:g}ms" for ts in ts_order]
    return pd.DataFrame(rows).sort_values(keys, kind="stable", na_position="last").reset_index(drop=True)


def trial_note(long: pd.DataFrame) -> str:
    parts = []
    for tr, g in long.groupby("tracker", sort=False):
        counts = ", ".join(f"{n} ({k} scenario{'s' if k > 1 else ''})" for n, k in g.groupby("trials").size().items())
        parts.append(f"{g['label'].iloc[0]} [{tr}] {counts}")
    return "Trials per cell: " + "; ".join(parts) + "."


def ts_note(long: pd.DataFrame) -> str:
    first = long.drop_duplicates("scenario")
    return "; ".join(f"{ts:g} ms: {', '.join(g['scenario'])}" for ts, g in first.groupby("ts_ms", sort=True))


def mean_rank_note(long: pd.DataFrame) -> str:
    """The mean-rank rule in words, with the scenario sets of ``long`` (:func:`mean_rank_sets`)."""
    parts = []
    for metric, name in (("theta_d", "theta_d"), ("total", "total phase")):
        sets = mean_rank_sets(long, metric)
        parts.append(f"{name}: " + "; ".join(f"{ts:g} ms over {len(scs)} ({', '.join(scs) or 'none'})" for ts, scs in sets.items()))
    return ("Mean rank (summary; in_mean_rank / in_mean_rank_total): per integration time, over the informative scenarios of that Ts "
            "on which every tracker run at that Ts ran, so each mean averages the same scenarios and competitors; "
            + "; ".join(parts) + ".")


def _no_interval_note(long: pd.DataFrame) -> str:
    """The words for an empty ci_overlaps_best, where some row has one."""
    return f", empty where there is {NO_INTERVAL}" if long["ci_overlaps_best"].isna().any() else ""


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
        "ci_overlaps_best: the 95% interval reaches the rank-1 tracker's" + _no_interval_note(long) + "; near_uniform: RMSE at least "
        f"{NEAR_UNIFORM:g} x pi/sqrt(3) = {NEAR_UNIFORM * UNIFORM_RMSE:.3g} rad (pi/sqrt(3) is the RMSE of a uniformly distributed wrapped "
        "error: lock on theta_d lost, or a scintillation phase beyond +-pi); informative / informative_total: some tracker of the "
        "scenario is below that level (otherwise the scenario's ranks are order among lost loops and count nowhere). "
        + mean_rank_note(long) + " outside_design: " + "; ".join(f"{t} on {d} data ({why})" for t, (d, why) in OUTSIDE_DESIGN.items())
        + ". A tracker run on one scenario in two experiments keeps the run with more trials (dropped_duplicate names the other). "
        "Integration times: " + ts + ". "
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
