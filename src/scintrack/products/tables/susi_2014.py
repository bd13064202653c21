"""Tables of Susi, Andreotti & Aquino 2014 (KF PLLs at 1 ms): the chapter's claims with numbers.

The chapter shows its results as plots only (Figs. 3-8) and states that the
KF PLLs have lower phase jitter than the 15-Hz PLL and that the SAKF PLL is
the best.  These tables put numbers with 95% intervals on those statements:

* **jitter** (``susi_table_jitter``): the phase jitter of the chapter (the
  standard deviation of the discriminator output over 60-s windows) and the
  jitter of the true tracking error ``wrap(theta_hat - theta_d - theta_s)``,
  per tracker and scenario.  Each trial's jitter is the mean over its
  steady-state windows; the table gives the mean over trials with its 95%
  interval, and the paired difference to the PLL per trial (every tracker
  sees the same realisations, so the difference removes the common part);
* **claims** (``susi_table_claims``): one row per claim and scenario with the
  paired differences it rests on and a verdict (holds / does not hold /
  inconclusive when a paired interval includes 0; not evaluated without an
  interval: from one trial the verdict cannot be stated);
* **eq. (12) sensitivity** (``susi_table_alpha``): the SAKF with other gain
  weightings ``w = alpha (1 + Phi3/phi_ref)^-gamma`` and without the
  scintillation process noise, beside the AKF and the default SAKF;
* **the AKF's cause** (``susi_table_akf_qjerk``, pre-declared reading): the
  AKF's steady-state loop bandwidth with the oscillator terms of Q only, the
  Doppler-jerk PSD q_jerk only and both (rule ``susi_akf_bandwidth``), and its
  jitter beside the PLL's for q_jerk over five decades, with where (if
  anywhere) its discriminator jitter meets the PLL's;
* **in-band strength** (``susi_table_inband``, pre-declared reading): the
  three loops with the scenario's scintillation phase scaled by 0.1-2
  (``trace.phase_scale``, amplitude unchanged; scale 1 is the chapter run),
  and per scale the tracker with the lowest discriminator jitter, stated with
  paired intervals.

Every number (trials, C/N0, Ts, windows) comes from the result attributes;
titles and notes say when a trace is a SYNTHETIC SURROGATE.
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
from .common import NO_INTERVAL, estimate_text

if TYPE_CHECKING:
    import xarray as xr

PAPER = "susi_2014"
SECTION = "Susi et al. 2014: KF PLLs at 1 ms"
CHAPTER = "susi_chapter"
ALPHA = "susi_alpha"
REFERENCE = "susi_pll"  # the chapter's 3rd-order 15-Hz PLL
AKF, SAKF = "susi_akf", "susi_sakf"
METRICS = {"discriminator": "jitter_discriminator", "tracking": "jitter_tracking"}
METRIC_TEXT = {"discriminator": "discriminator jitter", "tracking": "tracking-error jitter"}

# --- shared helpers (also used by the figures) -------------------------------------------------


def scenario_is_surrogate(config: Mapping[str, Any], scenario: str) -> bool:
    """True when a trace scenario's trace is a synthetic surrogate (False for non-trace scenarios)."""
    from ...data.susi_traces import uses_real

    sc = config["scenarios"][scenario]
    return "trace" in sc and not uses_real(config, sc["trace"]["name"])


def any_surrogate(config: Mapping[str, Any], scenarios: Sequence[str]) -> bool:
    return any(scenario_is_surrogate(config, sc) for sc in scenarios)


def experiment_scenarios(config: Mapping[str, Any], experiment: str) -> list[str]:
    return list(config["experiments"].get(experiment, {}).get("scenarios", []))


def source_text(ds: xr.Dataset) -> str:
    """What the scintillation of a Susi result (or index file) is."""
    name = str(ds.attrs.get("trace_name", "") or ds.attrs.get("scenario", ""))
    if ds.attrs.get("trace_source") == "real":
        return "real JRC Hanoi trace"
    if "_event" in name:  # scintrack.data.index_trace
        return "SYNTHETIC SURROGATE phase, driven by REAL BiScEF indices (each minute's slope p), not a recording"
    if "high_latitude" in name:
        return "SYNTHETIC SURROGATE phase screen, not the chapter's SPLN/Spirent data"
    if "equatorial" in name:
        return "SYNTHETIC SURROGATE phase screen, not the chapter's JRC Hanoi data"
    return "SYNTHETIC SURROGATE phase screen"


def is_surrogate_result(ds: xr.Dataset) -> bool:
    return ds.attrs.get("trace_source") != "real"


def short_source(ds: xr.Dataset) -> str:
    return "real" if ds.attrs.get("trace_source") == "real" else "SURROGATE"


def ts_ms(ds: xr.Dataset) -> str:
    return f"{float(ds.attrs['ts']) * 1000:g}"


def window_length_s(ds: xr.Dataset) -> float:
    """Length of the jitter windows, from their centres ((k + 1/2) L)."""
    w = np.asarray(ds["window"].values, dtype=float)
    return float(w[1] - w[0]) if w.size > 1 else float(2 * w[0])


def steady_windows(ds: xr.Dataset) -> np.ndarray:
    """Windows that start at or after ``steady_state_start_s`` (all windows if none does)."""
    w = np.asarray(ds["window"].values, dtype=float)
    keep = w - window_length_s(ds) / 2 >= float(ds.attrs["steady_state_start_s"]) - 1e-9
    return keep if keep.any() else np.ones_like(keep)


def has_jitter(ds: xr.Dataset, tracker: str) -> bool:
    return "jitter_discriminator" in ds and bool(np.isfinite(ds["jitter_discriminator"].sel(tracker=tracker).values).any())


def jitter_trackers(ds: xr.Dataset) -> list[str]:
    return [str(t) for t in ds["tracker"].values if has_jitter(ds, str(t))]


def trial_jitter(ds: xr.Dataset, tracker: str, metric: str = "discriminator") -> np.ndarray:
    """Per-trial jitter [rad]: mean over the steady-state windows."""
    v = ds[METRICS[metric]].sel(tracker=tracker).values[:, steady_windows(ds)]
    return np.nanmean(v, axis=1)


def paired(a: np.ndarray, b: np.ndarray) -> tuple[float, float, float]:
    """Mean of the per-trial difference a - b and its 95% interval (not clipped)."""
    m, lo, hi = mean_with_ci(np.asarray(a, float) - np.asarray(b, float), lower=None)
    return float(m), float(lo), float(hi)


def ci(values: np.ndarray, lower: float | None = 0.0) -> tuple[float, float, float]:
    m, lo, hi = mean_with_ci(np.asarray(values, float), lower=lower)
    return float(m), float(lo), float(hi)


def fmt_ci(m: float, lo: float, hi: float, digits: int = 4) -> str:
    """``m [lo, hi]`` (empty for a NaN ``m``; words in place of a missing interval, :func:`.common.estimate_text`)."""
    if not np.isfinite(m):
        return ""
    return estimate_text(m, lo, hi, f".{digits}g")


def conditions(ds: xr.Dataset) -> str:
    return f"C/N0 = {float(ds.attrs['cn0_dbhz']):g} dB-Hz, Ts = {ts_ms(ds)} ms, {int(ds['n_trials'])} trials"


def _by_experiment(results: Sequence[xr.Dataset], experiment: str) -> list[xr.Dataset]:
    return [r for r in results if r.attrs.get("experiment") == experiment]


def _same_trials(a: xr.Dataset, b: xr.Dataset) -> bool:
    return np.array_equal(a["trial"].values, b["trial"].values)


def _scenario_notes(results: Sequence[xr.Dataset]) -> str:
    parts = [f"{r.attrs['scenario']}: {conditions(r)}, {source_text(r)}" for r in results]
    same = (" Every trial of a trace scenario sees the same scintillation trace (thermal noise and clock differ), so the intervals "
            "cover noise realisations, not other scintillation events.") if any("trace_source" in r.attrs for r in results) else ""
    return "; ".join(parts) + "." + same


def _jitter_method(ds: xr.Dataset, reference: str = "PLL") -> str:
    nw = int(steady_windows(ds).sum())
    return (f"Jitter = std of the 1-ms discriminator output (chapter's metric) or of the true tracking error wrap(theta_hat - theta_d - theta_s) "
            f"over {window_length_s(ds):g}-s windows; per trial the mean over the {nw} windows that start after the "
            f"{float(ds.attrs['steady_state_start_s']):g}-s transient, then mean [95% interval] over trials. "
            f"Paired difference: per trial, tracker minus {reference} on the same realisation, then mean [95% interval].")


# --- susi_table_jitter ------------------------------------------------------------------------


def jitter_long(results: Sequence[xr.Dataset]) -> pd.DataFrame:
    """One row per scenario x tracker x metric: mean jitter and the paired difference to the PLL."""
    rows = []
    for res in results:
        label = tracker_labels(res)
        for tr in jitter_trackers(res):
            for metric in METRICS:
                v = trial_jitter(res, tr, metric)
                m, lo, hi = ci(v)
                if tr != REFERENCE and has_jitter(res, REFERENCE):
                    ref = trial_jitter(res, REFERENCE, metric)
                    d, dlo, dhi = paired(v, ref)
                    pct = 100 * d / float(np.mean(ref))
                else:
                    d = dlo = dhi = pct = np.nan
                rows.append({
                    "scenario": res.attrs["scenario"], "data": short_source(res), "tracker": tr, "label": label.get(tr, tr), "metric": metric,
                    "trials": int(res["n_trials"]), "windows": int(steady_windows(res).sum()), "window_s": window_length_s(res),
                    "jitter_rad": m, "ci95_lo": lo, "ci95_hi": hi,
                    "minus_pll_rad": d, "minus_pll_ci95_lo": dlo, "minus_pll_ci95_hi": dhi, "minus_pll_pct": pct,
                })
    return pd.DataFrame(rows)


def jitter_grid(long: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (sc, _tr), grp in long.groupby(["scenario", "tracker"], sort=False):
        g = grp.set_index("metric")
        row = {"scenario": sc, "data": g["data"].iloc[0], "tracker": g["label"].iloc[0], "trials": int(g["trials"].iloc[0])}
        for metric in METRICS:
            r = g.loc[metric]
            row[f"{METRIC_TEXT[metric]} [rad]"] = fmt_ci(r.jitter_rad, r.ci95_lo, r.ci95_hi)
            row[f"{METRIC_TEXT[metric]} minus PLL [rad]"] = fmt_ci(r.minus_pll_rad, r.minus_pll_ci95_lo, r.minus_pll_ci95_hi)
            row[f"{METRIC_TEXT[metric]} minus PLL [%]"] = "" if not np.isfinite(r.minus_pll_pct) else f"{r.minus_pll_pct:+.1f}"
        rows.append(row)
    return pd.DataFrame(rows)


def _chapter_inputs(config):
    return {sc: paths.exp_result(CHAPTER, sc) for sc in experiment_scenarios(config, CHAPTER)}


def _chapter_surrogate(config) -> bool:
    return any_surrogate(config, experiment_scenarios(config, CHAPTER))


def _jitter_inputs(config):
    """The chapter results and, when the chapter has scenarios, their jitter bound (rule susi_jitter_bound)."""
    from ...pipeline.params import SUSI_JITTER_BOUND

    out = _chapter_inputs(config)
    return {**out, "jitter_bound": SUSI_JITTER_BOUND} if out else out


# --- the jitter bound beside the jitter cells ----------------------------------------------------

BOUND_PRODUCT = "susi_jitter_bound"  # the ``product`` attribute of results/susi_2014/jitter_bound.nc
BOUND_NOISE_MODEL = "fading"  # the best loop of the scenario as simulated: prompt noise R / rho^2
#: long-form column -> (grid column, the bound file's variable), inserted after the discriminator jitter
DISCRIMINATOR_BOUNDS = {
    "bound_rad": ("bound: predictor + thermal [rad] (jitter above it)", "bound_rad"),
    "bound_fading_rad": ("bound with the trace's fading [rad] (jitter above it)", "bound_fading_rad"),
    "wiener_bound_rad": ("Wiener bound, no fading [rad] (jitter above it)", "wiener_bound_rad"),
}
TRACKING_BOUND = ("tracking-error bound, no fading [rad] (jitter above it)", "tracking_bound_rad")
BEST_LOOP = "best 3rd-order PLL, linear model [rad] (jitter above it)"


def is_bound(ds: xr.Dataset) -> bool:
    return ds.attrs.get("product") == BOUND_PRODUCT


def bound_note(bound: xr.Dataset) -> str:
    cn0s = ", ".join(f"{float(c):g} dB-Hz" for c in np.atleast_1d(bound["cn0_dbhz"].values))
    return ("Bounds (per scenario, the same for every tracker; rule susi_jitter_bound, scintrack.experiments.prediction_bound): "
            "'predictor + thermal' = sqrt(sigma^2_pred + 1/(2 C/N0 T)), sigma^2_pred the one-step prediction error variance of the noise-free "
            "tracked phase (scintillation + receiver clock) from its spectrum (Kolmogorov-Szego formula on a Welch estimate of the phase increments), "
            f"at {cn0s}: no tracker's discriminator jitter is below it. 'with the trace's fading' replaces 1/(2 C/N0 T) by its mean over the "
            "window divided by the trace's squared amplitude, the thermal noise the prompts carry. 'Wiener' = sqrt of the innovation variance of "
            "the measured phase (phase + white thermal noise, no fading): the smallest discriminator jitter of any linear causal tracker, reached "
            "by the Wiener predictor; 'tracking-error bound' = sqrt(R (1 - R / innovation variance)), the error of the best causal filtered "
            "phase, beside the tracking-error jitter. 'best 3rd-order PLL': the chapter's loop filter in the linear model (prompt noise "
            f"R / rho^2) swept over Bn = 2-40 Hz, its smallest discriminator jitter and Bn, over {int(bound.attrs['loop_trials'])} noise "
            "realisations. Each is the mean over the same steady-state windows as the jitter.")


def add_bounds(long: pd.DataFrame, grid: pd.DataFrame, bound: xr.Dataset) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``long`` and ``grid`` with the bound columns of each row's scenario (NaN / empty for a scenario the bound lacks)."""
    scenarios = [str(s) for s in bound["scenario"].values]

    def value(sc: str, var: str, **sel) -> float:
        return float(bound[var].sel(scenario=sc, **sel)) if sc in scenarios else np.nan

    long = long.copy()
    disc = long["metric"] == "discriminator"
    for col, (_, var) in DISCRIMINATOR_BOUNDS.items():
        long[col] = [value(sc, var) if d else np.nan for sc, d in zip(long["scenario"], disc)]
    long["tracking_bound_rad"] = [np.nan if d else value(sc, TRACKING_BOUND[1]) for sc, d in zip(long["scenario"], disc)]
    long["best_loop_rad"] = [value(sc, "best_pll_jitter_rad", noise_model=BOUND_NOISE_MODEL) if d else np.nan for sc, d in zip(long["scenario"], disc)]
    long["best_loop_bandwidth_hz"] = [value(sc, "best_bandwidth_hz", noise_model=BOUND_NOISE_MODEL) if d else np.nan
                                      for sc, d in zip(long["scenario"], disc)]

    jitter = {(r.scenario, r.label, r.metric): r.jitter_rad for r in long.itertuples()}

    def cell(sc: str, label: str, metric: str, v: float, extra: str = "") -> str:
        """``bound (+x%)``: the bound and how far the row's jitter lies above it (text, so that the Markdown keeps 4 digits)."""
        if not np.isfinite(v):
            return ""
        above = 100.0 * (jitter.get((sc, label, metric), np.nan) / v - 1.0)
        return f"{v:.4g}{extra}" + (f" ({above:+.1f}%)" if np.isfinite(above) else "")

    rows = list(zip(grid["scenario"], grid["tracker"]))
    new = {name: [cell(sc, lb, "discriminator", value(sc, var)) for sc, lb in rows] for name, var in DISCRIMINATOR_BOUNDS.values()}
    new[BEST_LOOP] = [cell(sc, lb, "discriminator", value(sc, "best_pll_jitter_rad", noise_model=BOUND_NOISE_MODEL),
                           f" at Bn {value(sc, 'best_bandwidth_hz', noise_model=BOUND_NOISE_MODEL):g} Hz") for sc, lb in rows]
    new[TRACKING_BOUND[0]] = [cell(sc, lb, "tracking", value(sc, TRACKING_BOUND[1])) for sc, lb in rows]
    columns = list(grid.columns)
    after_disc = columns.index(f"{METRIC_TEXT['discriminator']} [rad]") + 1
    after_track = columns.index(f"{METRIC_TEXT['tracking']} [rad]") + 1
    order = (columns[:after_disc] + [c for c in new if c != TRACKING_BOUND[0]] + columns[after_disc:after_track] + [TRACKING_BOUND[0]]
             + columns[after_track:])
    grid = grid.assign(**new)
    return long, grid[order]


def _data_title(results: Sequence[xr.Dataset]) -> str:
    return " (SURROGATE data)" if any(is_surrogate_result(r) for r in results) else ""


@table("susi_table_jitter", ["table_jitter", "table_jitter_long"], paper=PAPER, section=SECTION, inputs=_jitter_inputs, surrogate=_chapter_surrogate)
def susi_table_jitter(*results: xr.Dataset) -> dict:
    """Phase jitter per tracker and scenario with 95% intervals and the paired difference to the PLL, and the
    jitter bound of each scenario beside it (when the bound file is among the inputs)."""
    bounds = [r for r in results if is_bound(r)]
    results = [r for r in results if not is_bound(r)]
    long = jitter_long(results)
    grid = jitter_grid(long)
    note = _jitter_method(results[0]) + " " + _scenario_notes(results)
    if bounds:
        long, grid = add_bounds(long, grid, bounds[0])
        note += " " + bound_note(bounds[0])
    title = f"Susi et al. 2014: phase jitter of the PLL, AKF PLL and SAKF PLL{_data_title(results)}"
    return {
        "table_jitter": (grid, title, note),
        "table_jitter_long": (long, title + ", long form", note),
    }


# --- susi_table_claims ------------------------------------------------------------------------

#: claim -> (claimed-lower tracker, other tracker) pairs the claim needs
CLAIMS = {
    "both KF PLLs have lower jitter than the PLL": ((AKF, REFERENCE), (SAKF, REFERENCE)),
    "SAKF has the lowest jitter": ((SAKF, REFERENCE), (SAKF, AKF)),
}
#: where the chapter states each claim, per trace
CHAPTER_TEXT = {
    ("high_latitude", 0): "Fig. 5: 'the KF based schemes outperform the traditional PLL scheme'",
    ("high_latitude", 1): "Fig. 4: 'the SAKF shows the best performance in terms of noise reduction'",
    ("equatorial", 0): "Figs. 7-8: 'the KF schemes allow reducing the noise if compared with the traditional PLL'",
    ("equatorial", 1): "Figs. 7-8: 'again the SAKF PLL achieves the best results'",
}


def verdict(intervals: Sequence[tuple[float, float, float]]) -> str:
    """Verdict of a claim that every difference (claimed-lower minus other) is negative.

    holds: every 95% interval lies below 0; does not hold: some interval lies
    above 0 (significantly the other way); inconclusive: otherwise (an
    interval includes 0).  Not evaluated: a difference is missing, or has no
    interval (:data:`NO_INTERVAL`), and the claim is then not stated either way.
    """
    if not intervals or any(not np.isfinite(m) for m, _, _ in intervals):
        return "not evaluated"
    if any(not np.all(np.isfinite(iv)) for iv in intervals):
        return f"not evaluated: {NO_INTERVAL}"
    if all(hi < 0 for _, _, hi in intervals):
        return "holds"
    if any(lo > 0 for _, lo, _ in intervals):
        return "does not hold"
    return "inconclusive"


def claims_frame(results: Sequence[xr.Dataset]) -> pd.DataFrame:
    rows = []
    for res in results:
        label = tracker_labels(res)
        trace = str(res.attrs.get("trace_name", res.attrs["scenario"]))
        for k, (claim, pairs) in enumerate(CLAIMS.items()):
            row = {"scenario": res.attrs["scenario"], "data": short_source(res), "claim": claim,
                   "chapter": next((v for (name, j), v in CHAPTER_TEXT.items() if j == k and name in trace), "")}
            for metric in METRICS:
                ivs, texts = [], []
                for a, b in pairs:
                    if has_jitter(res, a) and has_jitter(res, b):
                        iv = paired(trial_jitter(res, a, metric), trial_jitter(res, b, metric))
                        texts.append(f"{label.get(a, a)} - {label.get(b, b)} = {fmt_ci(*iv)}")
                    else:
                        iv = (np.nan, np.nan, np.nan)
                        texts.append(f"{label.get(a, a)} - {label.get(b, b)}: missing")
                    ivs.append(iv)
                row[f"{METRIC_TEXT[metric]} paired differences [rad]"] = "; ".join(texts)
                row[f"verdict ({METRIC_TEXT[metric]})"] = verdict(ivs)
            row["trials"] = int(res["n_trials"])
            rows.append(row)
    return pd.DataFrame(rows)


@table("susi_table_claims", ["table_claims"], paper=PAPER, section=SECTION, inputs=_chapter_inputs, surrogate=_chapter_surrogate)
def susi_table_claims(*results: xr.Dataset) -> dict:
    """The chapter's two claims per scenario, tested with paired differences of the per-trial jitter."""
    note = ("Verdict: holds = every paired 95% interval below 0; does not hold = some interval above 0; inconclusive = an interval includes 0 "
            "(intervals are not adjusted for the two comparisons per claim). The chapter's claims are about the discriminator jitter "
            "(its Figs. 4-5, 8); the tracking-error jitter is against the true total phase (dynamics + clock + scintillation), which the chapter "
            "could not measure. " + _jitter_method(results[0]) + " " + _scenario_notes(results))
    frame = claims_frame(results)
    if frame.filter(like="verdict").apply(lambda col: col.str.endswith(NO_INTERVAL)).any(axis=None):
        note += f" Not evaluated: {NO_INTERVAL}, so no paired interval and no verdict either way."
    return {"table_claims": (frame, f"Susi et al. 2014: do the chapter's claims hold?{_data_title(results)}", note)}


# --- susi_table_alpha -------------------------------------------------------------------------


def _alpha_inputs(config):
    chapter = set(experiment_scenarios(config, CHAPTER))
    out = {}
    for sc in experiment_scenarios(config, ALPHA):
        if sc in chapter:
            out[f"{CHAPTER}__{sc}"] = paths.exp_result(CHAPTER, sc)
        out[f"{ALPHA}__{sc}"] = paths.exp_result(ALPHA, sc)
    return out


def _alpha_surrogate(config) -> bool:
    return any_surrogate(config, experiment_scenarios(config, ALPHA))


def _steady_mean(ds: xr.Dataset, var: str, tracker: str) -> float:
    if var not in ds:
        return np.nan
    v = ds[var].sel(tracker=tracker).values
    t = ds["time"].values
    v = v[t >= float(ds.attrs["steady_state_start_s"])]
    return float(np.nanmean(v)) if np.isfinite(v).any() else np.nan


def alpha_long(results: Sequence[xr.Dataset]) -> pd.DataFrame:
    """One row per scenario x tracker: the AKF and SAKF of the chapter run, then the eq. (12) variants."""
    chapter = {r.attrs["scenario"]: r for r in _by_experiment(results, CHAPTER)}
    rows = []
    for res in _by_experiment(results, ALPHA):
        sc = res.attrs["scenario"]
        base = chapter.get(sc)
        entries = [(base, tr) for tr in (AKF, SAKF) if base is not None and tr in base["tracker"].values]
        entries += [(res, str(tr)) for tr in res["tracker"].values]
        ref = trial_jitter(base, SAKF) if base is not None and has_jitter(base, SAKF) else None
        for ds, tr in entries:
            label = tracker_labels(ds).get(tr, tr)
            row = {"scenario": sc, "data": short_source(ds), "tracker": tr, "label": label, "experiment": ds.attrs.get("experiment", ""),
                   "trials": int(ds["n_trials"])}
            for metric in METRICS:
                m, lo, hi = ci(trial_jitter(ds, tr, metric)) if has_jitter(ds, tr) else (np.nan,) * 3
                row.update({f"{metric}_jitter_rad": m, f"{metric}_ci95_lo": lo, f"{metric}_ci95_hi": hi})
            if ref is not None and has_jitter(ds, tr) and _same_trials(ds, base) and not (ds is base and tr == SAKF):
                d, dlo, dhi = paired(trial_jitter(ds, tr), ref)
            else:
                d = dlo = dhi = np.nan
            row.update({"discriminator_minus_sakf_rad": d, "minus_sakf_ci95_lo": dlo, "minus_sakf_ci95_hi": dhi})
            st = ds.sel(tracker=tr, kind="wrapped")
            row.update({"rmse_wrapped_rad": float(st["steady_rmse"]), "rmse_ci95_lo": float(st["steady_rmse_lo"]), "rmse_ci95_hi": float(st["steady_rmse_hi"])})
            m, lo, hi = ci(ds["slip_events"].sel(tracker=tr).values)
            row.update({"slip_events": m, "slip_events_ci95_lo": lo, "slip_events_ci95_hi": hi})
            row["mean_weight"] = _steady_mean(ds, "weight_mean", tr)
            row["mean_phi3_rad"] = _steady_mean(ds, "phi3_mean", tr)
            rows.append(row)
    return pd.DataFrame(rows)


def alpha_grid(long: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for r in long.itertuples():
        rows.append({
            "scenario": r.scenario, "data": r.data, "tracker": r.label, "trials": r.trials,
            "discriminator jitter [rad]": fmt_ci(r.discriminator_jitter_rad, r.discriminator_ci95_lo, r.discriminator_ci95_hi),
            "minus SAKF (paired) [rad]": fmt_ci(r.discriminator_minus_sakf_rad, r.minus_sakf_ci95_lo, r.minus_sakf_ci95_hi),
            "tracking-error jitter [rad]": fmt_ci(r.tracking_jitter_rad, r.tracking_ci95_lo, r.tracking_ci95_hi),
            "theta_d RMSE wrapped [rad]": fmt_ci(r.rmse_wrapped_rad, r.rmse_ci95_lo, r.rmse_ci95_hi),
            "slip events per run": fmt_ci(r.slip_events, r.slip_events_ci95_lo, r.slip_events_ci95_hi),
            "mean gain weight w": "" if not np.isfinite(r.mean_weight) else f"{r.mean_weight:.3g}",
            "mean on-line Phi3 [rad]": "" if not np.isfinite(r.mean_phi3_rad) else f"{r.mean_phi3_rad:.3g}",
        })
    return pd.DataFrame(rows)


@table("susi_table_alpha", ["table_alpha", "table_alpha_long"], paper=PAPER, section=SECTION, inputs=_alpha_inputs, surrogate=_alpha_surrogate)
def susi_table_alpha(*results: xr.Dataset) -> dict:
    """Sensitivity of the SAKF to the eq. (12) gain weighting and to the scintillation process noise."""
    long = alpha_long(results)
    alpha = _by_experiment(results, ALPHA)
    ref = alpha[0]
    note = ("The chapter gives neither alpha nor K(Phi3); our SAKF uses w = alpha (1 + Phi3/phi_ref)^-gamma with alpha = 1, gamma = 1, "
            "phi_ref = 0.5 rad (labels give each variant's change; 'no scint. Q' drops eqs. (7)-(8)). AKF and SAKF rows come from the "
            f"{CHAPTER} run, the variants from {ALPHA}; every run sees the same realisations per trial, so 'minus SAKF' is a paired "
            "difference of the per-trial discriminator jitter. theta_d RMSE: wrapped error against the dynamics phase (Vila-Valls's metric; "
            f"it counts the scintillation phase a tracker follows as error) after {float(ref.attrs['steady_state_start_s']):g} s; slip events "
            "counted on the same error over the whole run. Mean w and Phi3: mean over trials and over the steady-state part. "
            + _jitter_method(ref, "SAKF") + " " + _scenario_notes(alpha))
    title = f"Susi et al. 2014: SAKF sensitivity to the eq. (12) gain weighting{_data_title(alpha)}"
    return {"table_alpha": (alpha_grid(long), title, note), "table_alpha_long": (long, title + ", long form", note)}


# --- susi_table_real_indices: the REAL Septentrio indices beside the SURROGATE scenarios --------

#: (variable, label, unit) of the indices compared, in the order of the table and the figure's panels
REAL_INDICES = (("phi60", "Phi60", "rad"), ("s4", "S4", "1"), ("T", "T", "rad^2/Hz"), ("p", "p", "1"))
#: the percentiles of the real distributions the table gives
REAL_PERCENTILES = (50, 90, 99)


def real_indices_inputs(config) -> dict[str, str]:
    """The real BiScEF rows (first), then the indices of every Susi trace scenario (config order)."""
    from ...pipeline import params as P

    return {"biscef": P.SUSI_BISCEF_INDICES, **{f"indices_{sc}": paths.susi_indices_path(sc) for sc in P.susi_scenarios(config)}}


def real_stations(biscef: xr.Dataset) -> list[tuple[str, str]]:
    """(receiver code, station name) of the stations of a BiScEF rows file, in file order."""
    return [(code, str(biscef.attrs.get(f"{code}_station_name", code))) for code in str(biscef.attrs["stations"]).split(",")]


def station_values(biscef: xr.Dataset, code: str, var: str) -> np.ndarray:
    """The finite values of ``var`` at station ``code``."""
    v = np.asarray(biscef[var].values, dtype=float)[np.asarray(biscef["station"].values).astype(str) == code]
    return v[np.isfinite(v)]


def scenario_minutes(ind: xr.Dataset) -> dict[str, np.ndarray]:
    """Per index window (60 s in the full config) of a Susi scenario: the noise-free S4 and Phi60, and the
    median T and p of the 3-s power-law fits that end inside the window."""
    w = np.asarray(ind["window"].values, dtype=float)
    half = float(ind.attrs["window_s"]) / 2
    t = np.asarray(ind["tp_time"].values, dtype=float)
    out = {"phi60": np.asarray(ind["phi60_true"].values, dtype=float), "s4": np.asarray(ind["s4_true"].values, dtype=float)}
    for var in ("T", "p"):
        values = np.asarray(ind[f"{var}_true"].values, dtype=float)
        inside = [(t > c - half) & (t <= c + half) & np.isfinite(values) for c in w]
        out[var] = np.array([float(np.median(values[m])) if m.any() else np.nan for m in inside])
    return out


def scenario_name(ind: xr.Dataset) -> str:
    where = {"susi_high_latitude": "high-latitude", "susi_equatorial": "equatorial", "susi_high_latitude_event": "real-index event (Phi60)",
             "susi_high_latitude_event_T": "real-index event (Ts1)"}.get(str(ind.attrs["scenario"]), str(ind.attrs["scenario"]))
    return f"{where} scenario ({short_source(ind)})"


def real_event(biscef: xr.Dataset) -> dict[str, Any]:
    """The chosen event from the ``event_*`` attributes."""
    a = biscef.attrs
    keys = ("station", "station_name", "prn", "time_utc", "elevation", "azimuth", "phi60", "s4", "s4_correction", "T", "p", "cn0")
    return {k: a[f"event_{k}"] for k in keys}


def real_indices_long(biscef: xr.Dataset, indices: Sequence[xr.Dataset]) -> pd.DataFrame:
    """One row per (index, source): count, min, median, 90th/99th percentile and max of each real station, of each
    scenario's windows (no percentiles: a handful of windows) and of the chosen event (its one value)."""
    rows = []
    ev = real_event(biscef)
    for var, label, unit in REAL_INDICES:
        name = f"{label} [{unit}]" if unit != "1" else label
        for code, station in real_stations(biscef):
            v = station_values(biscef, code, var)
            q = np.percentile(v, REAL_PERCENTILES) if v.size else [np.nan] * len(REAL_PERCENTILES)
            rows.append({"index": name, "data": "real", "source": f"{station} ({code})", "count": int(v.size),
                         "min": float(v.min()) if v.size else np.nan, "median": q[0], "p90": q[1], "p99": q[2],
                         "max": float(v.max()) if v.size else np.nan})
        for ind in indices:
            v = scenario_minutes(ind)[var]
            v = v[np.isfinite(v)]
            rows.append({"index": name, "data": short_source(ind), "source": scenario_name(ind), "count": int(v.size),
                         "min": float(v.min()) if v.size else np.nan, "median": float(np.median(v)) if v.size else np.nan,
                         "p90": np.nan, "p99": np.nan, "max": float(v.max()) if v.size else np.nan})
        rows.append({"index": name, "data": "real", "source": f"chosen event: {ev['station_name']} PRN {int(ev['prn'])} {ev['time_utc']} UTC",
                     "count": 1, "min": float(ev[var]), "median": float(ev[var]), "p90": np.nan, "p99": np.nan, "max": float(ev[var])})
    return pd.DataFrame(rows)


def _g(value: float) -> str:
    return "" if not np.isfinite(value) else f"{value:.3g}"


def real_indices_grid(long: pd.DataFrame) -> pd.DataFrame:
    """The long form as read: percentiles of the real stations, the range of the scenarios' windows, the event's value."""
    rows = []
    for r in long.itertuples():
        event = r.source.startswith("chosen event")
        scenario = r.data != "real"
        rows.append({"index": r.index, "data": r.data, "source": r.source, "count": "" if event else str(int(r.count)),
                     "median": "" if event else _g(r.median), "90th percentile": "" if event or scenario else _g(r.p90),
                     "99th percentile": "" if event or scenario else _g(r.p99), "max": "" if event else _g(r.max),
                     "range": f"{_g(r.min)} - {_g(r.max)}" if scenario else "", "value": _g(r.median) if event else ""})
    return pd.DataFrame(rows)


def real_event_frame(biscef: xr.Dataset) -> pd.DataFrame:
    ev = real_event(biscef)
    return pd.DataFrame([{
        "station": f"{ev['station_name']} ({ev['station']})", "GPS PRN": int(ev["prn"]), "UTC": str(ev["time_utc"]),
        "elevation [deg]": float(ev["elevation"]), "azimuth [deg]": float(ev["azimuth"]), "Phi60 [rad]": float(ev["phi60"]),
        "S4 (noise part removed)": float(ev["s4"]), "S4 noise correction": float(ev["s4_correction"]), "T [rad^2/Hz]": float(ev["T"]),
        "p": float(ev["p"]), "C/N0 [dB-Hz]": float(ev["cn0"]),
    }])


def _real_note(biscef: xr.Dataset, indices: Sequence[xr.Dataset]) -> str:
    mask = float(biscef.attrs["elevation_min_deg"])
    windows = sorted({float(ind.attrs["window_s"]) for ind in indices})
    return (f"Real: Septentrio ISMR indices in BiScEF files (Tromsø PolaRx5S, Ny-Ålesund PolaRxS, 2023-01-15; kartverket/BiScEF, MIT), "
            f"GPS L1 C/A, elevation >= {mask:g} deg, one value per satellite-minute. Count: satellite-minutes with a value (real), windows "
            "(scenarios). S4 is the receiver's "
            "S4 with its thermal-noise part removed (S4s1; 0 where the correction exceeds the total, as in most quiet minutes); Phi60 after the "
            "receiver's 0.1-Hz 6th-order Butterworth high-pass; T = phase PSD at 1 Hz and p = slope of the 0.1-25 Hz phase spectrum, fitted "
            "by the receiver over each minute. Surrogate scenarios (the Susi 2014 runs): per "
            + "/".join(f"{w:g}" for w in windows) + "-s window of the noise-free trace, S4 of the detrended intensity and Phi60 after a "
            "zero-phase 0.1-Hz high-pass; T and p are the medians per window of 3-s power-law fits over 0.5-5 Hz (a narrower band than the "
            "receiver's). Chosen event: the minute with the largest L1 Phi60 of a GPS satellite at elevation >= "
            f"{mask:g} deg over both files (rule fixed before any run, docs/REPRODUCTION.md); its values are those of that one minute.")


@table("susi_table_real_indices", ["table_real_indices_vs_surrogate", "table_real_indices_vs_surrogate_long", "table_real_event"], paper=PAPER, section=SECTION,
       inputs=real_indices_inputs, surrogate=lambda config: False)
def susi_table_real_indices(biscef: xr.Dataset, *indices: xr.Dataset) -> dict:
    """The real Septentrio index distributions per station beside the surrogate scenarios' ranges, and the chosen event."""
    note = _real_note(biscef, indices)
    ev = real_event(biscef)
    long = real_indices_long(biscef, indices)
    title = "Susi et al. 2014: REAL Septentrio scintillation indices (Tromsø, Ny-Ålesund, 2023-01-15) beside the SURROGATE scenarios"
    return {
        "table_real_indices_vs_surrogate": (real_indices_grid(long), title, note),
        "table_real_indices_vs_surrogate_long": (long, title + ", long form", note),
        "table_real_event": (real_event_frame(biscef),
                             f"Susi et al. 2014: the REAL event chosen for the high-latitude scenario ({ev['station_name']}, GPS PRN "
                             f"{int(ev['prn'])}, {ev['time_utc']} UTC)", note),
    }


# --- susi_table_akf_qjerk and susi_table_inband: the pre-declared readings of the AKF's cause and of the in-band
# strength (docs/REPRODUCTION.md, "Susi 2014 and Zhao: readings of the open verdicts") ---------------------------

QJERK = "susi_akf_qjerk"
INBAND = "susi_inband"
#: the ``product`` attribute of results/susi_2014/akf_qjerk_bandwidth.nc (rule susi_akf_bandwidth)
BANDWIDTH_PRODUCT = "susi_akf_bandwidth"
INBAND_TRACKERS = (REFERENCE, AKF, SAKF)
#: the Q terms of the bandwidth file and their column names
BANDWIDTH_TERMS = {"both": "B_L, oscillator + q_jerk [Hz]", "oscillator": "B_L, oscillator only [Hz]", "q_jerk": "B_L, q_jerk only [Hz]"}


def versus(lo: float, hi: float, other: str = "PLL") -> str:
    """Where a paired 95% interval lies: ``below <other>``, ``above <other>`` or ``meets <other>`` (it includes 0)."""
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return ""
    return f"below {other}" if hi < 0 else f"above {other}" if lo > 0 else f"meets {other} (interval includes 0)"


def _qjerk_inputs(config):
    """The bandwidth file (rule susi_akf_bandwidth), then the q_jerk sweep's result of each scenario."""
    from ...pipeline.params import SUSI_AKF_BANDWIDTH

    scenarios = experiment_scenarios(config, QJERK)
    return {"bandwidth": SUSI_AKF_BANDWIDTH, **{f"{QJERK}__{sc}": paths.exp_result(QJERK, sc) for sc in scenarios}} if scenarios else {}


def _qjerk_surrogate(config) -> bool:
    return any_surrogate(config, experiment_scenarios(config, QJERK))


def qjerk_label(q: float) -> str:
    return f"AKF PLL, q_jerk = {q:g} Hz^2/s^3"


def qjerk_long(bandwidth: xr.Dataset, results: Sequence[xr.Dataset]) -> pd.DataFrame:
    """One row per scenario x tracker (the PLL, then the AKFs by q_jerk): steady-state bandwidth per Q term, discriminator
    and tracking-error jitter with 95% intervals and the paired difference to the PLL."""
    rows = []
    for res in results:
        sc = str(res.attrs["scenario"])
        label = tracker_labels(res)
        akfs = sorted((str(t) for t in bandwidth["tracker"].values if str(t) in res["tracker"].values),
                      key=lambda t: float(bandwidth["q_jerk_hz2_s3"].sel(tracker=t)))
        for tr in [REFERENCE, *akfs]:
            if not has_jitter(res, tr):
                continue
            is_akf = tr != REFERENCE
            q = float(bandwidth["q_jerk_hz2_s3"].sel(tracker=tr)) if is_akf else np.nan
            row = {"scenario": sc, "data": short_source(res), "tracker": tr, "label": qjerk_label(q) if is_akf else label.get(tr, tr),
                   "trials": int(res["n_trials"]), "q_jerk_hz2_s3": q}
            for term in BANDWIDTH_TERMS:
                row[f"bandwidth_{term}_hz"] = (float(bandwidth["bandwidth_hz"].sel(scenario=sc, tracker=tr, term=term))
                                               if is_akf and sc in bandwidth["scenario"].values else np.nan)
            for metric in METRICS:
                m, lo, hi = ci(trial_jitter(res, tr, metric))
                d, dlo, dhi = paired(trial_jitter(res, tr, metric), trial_jitter(res, REFERENCE, metric)) if is_akf else (np.nan,) * 3
                row.update({f"{metric}_jitter_rad": m, f"{metric}_ci95_lo": lo, f"{metric}_ci95_hi": hi,
                            f"{metric}_minus_pll_rad": d, f"{metric}_minus_pll_ci95_lo": dlo, f"{metric}_minus_pll_ci95_hi": dhi})
            row["discriminator_vs_pll"] = versus(row["discriminator_minus_pll_ci95_lo"], row["discriminator_minus_pll_ci95_hi"])
            rows.append(row)
    return pd.DataFrame(rows)


def qjerk_meeting(long: pd.DataFrame, scenario: str) -> str:
    """Where, in the q_jerk sweep, the AKF's discriminator jitter meets the PLL's on ``scenario``: the q_jerk whose paired
    interval includes 0, else the two neighbouring values between which the paired difference changes sign (with the
    crossing by linear interpolation in log q_jerk), else the sweep's closest value."""
    akf = long[(long["scenario"] == scenario) & np.isfinite(long["q_jerk_hz2_s3"])].sort_values("q_jerk_hz2_s3")
    if akf.empty:
        return ""
    meets = akf[akf["discriminator_vs_pll"].str.startswith("meets")]
    if not meets.empty:
        return "meets the PLL at q_jerk = " + ", ".join(f"{q:g}" for q in meets["q_jerk_hz2_s3"]) + " Hz^2/s^3 (paired interval includes 0)"
    q, d = akf["q_jerk_hz2_s3"].to_numpy(float), akf["discriminator_minus_pll_rad"].to_numpy(float)
    for k in range(len(q) - 1):
        if np.sign(d[k]) != np.sign(d[k + 1]):
            x = np.log10(q[k]) + (np.log10(q[k + 1]) - np.log10(q[k])) * d[k] / (d[k] - d[k + 1])
            return (f"crosses the PLL between q_jerk = {q[k]:g} and {q[k + 1]:g} Hz^2/s^3 (about {10 ** x:.2g} by linear "
                    "interpolation in log q_jerk)")
    best = int(np.argmin(np.abs(d)))
    side = "above" if d[best] > 0 else "below"
    return (f"does not meet the PLL within the sweep: every AKF is {side} it, closest at q_jerk = {q[best]:g} Hz^2/s^3 "
            f"({d[best]:+.4f} rad)")


def qjerk_grid(long: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for r in long.to_dict("records"):
        row = {"scenario": r["scenario"], "data": r["data"], "tracker": r["label"], "trials": r["trials"],
               "q_jerk [Hz^2/s^3]": "" if not np.isfinite(r["q_jerk_hz2_s3"]) else f"{r['q_jerk_hz2_s3']:g}"}
        for term, col in BANDWIDTH_TERMS.items():
            v = r[f"bandwidth_{term}_hz"]
            row[col] = "" if not np.isfinite(v) else f"{v:.3g}"
        for metric in METRICS:
            row[f"{METRIC_TEXT[metric]} [rad]"] = fmt_ci(r[f"{metric}_jitter_rad"], r[f"{metric}_ci95_lo"], r[f"{metric}_ci95_hi"])
            row[f"{METRIC_TEXT[metric]} minus PLL [rad]"] = fmt_ci(r[f"{metric}_minus_pll_rad"], r[f"{metric}_minus_pll_ci95_lo"],
                                                                   r[f"{metric}_minus_pll_ci95_hi"])
            if metric == "discriminator":
                row["discriminator jitter vs PLL"] = r["discriminator_vs_pll"]
        rows.append(row)
    return pd.DataFrame(rows)


@table("susi_table_akf_qjerk", ["table_akf_qjerk", "table_akf_qjerk_long"], paper=PAPER, section=SECTION, inputs=_qjerk_inputs,
       surrogate=_qjerk_surrogate)
def susi_table_akf_qjerk(bandwidth: xr.Dataset, *results: xr.Dataset) -> dict:
    """The AKF PLL's steady-state loop bandwidth split into its oscillator and q_jerk terms, and its jitter beside the PLL's,
    for q_jerk over five decades (the chapter does not give it)."""
    long = qjerk_long(bandwidth, results)
    meeting = "; ".join(f"{sc}: {qjerk_meeting(long, sc)}" for sc in dict.fromkeys(long["scenario"]))
    clocks = ", ".join(f"{sc}: {bandwidth['clock'].sel(scenario=sc).item()} at {float(bandwidth['cn0_dbhz'].sel(scenario=sc)):g} dB-Hz"
                       for sc in bandwidth["scenario"].values)
    note = ("B_L: noise bandwidth sum(h^2)/(2 Ts) of the steady-state loop, the Riccati gain of the AKF's Q and R = eq. (10) at the "
            "scenario's C/N0 (rule susi_akf_bandwidth, scintrack.experiments.susi_akf_bandwidth): with the whole Q (oscillator of eqs. "
            "5-6 + the Doppler-jerk PSD q_jerk on the rate state), with q_jerk = 0 (oscillator only: a second-order loop) and with the "
            f"oscillator's PSDs at 0 (q_jerk only). Oscillators: {clocks}. The chapter gives no q_jerk; the sweep covers five decades "
            f"around the shared value, every variant run on the same realisations as the PLL. Where the AKF meets the PLL: {meeting}. "
            "vs PLL: below / above = the paired 95% interval of the discriminator-jitter difference lies below / above 0. "
            + _jitter_method(results[0]) + " " + _scenario_notes(results))
    title = f"Susi et al. 2014: the AKF PLL's bandwidth and jitter against its Doppler-jerk PSD q_jerk{_data_title(results)}"
    return {"table_akf_qjerk": (qjerk_grid(long), title, note), "table_akf_qjerk_long": (long, title + ", long form", note)}


def _inband_inputs(config):
    """The chapter run of each unscaled scenario (scale 1) whose trace the in-band sweep scales, then the sweep's results."""
    scaled = experiment_scenarios(config, INBAND)
    traces = {config["scenarios"][sc]["trace"]["name"] for sc in scaled if "trace" in config["scenarios"][sc]}
    base = [sc for sc in experiment_scenarios(config, CHAPTER)
            if "trace" in config["scenarios"][sc] and config["scenarios"][sc]["trace"]["name"] in traces]
    return {**{f"{CHAPTER}__{sc}": paths.exp_result(CHAPTER, sc) for sc in base}, **{f"{INBAND}__{sc}": paths.exp_result(INBAND, sc) for sc in scaled}}


def _inband_surrogate(config) -> bool:
    return any_surrogate(config, experiment_scenarios(config, INBAND))


def phase_scale(ds: xr.Dataset) -> float:
    """The factor on the trace's scintillation phase of a result (1 for the unscaled scenario)."""
    return float(ds.attrs.get("trace_phase_scale", 1.0))


def site(ds: xr.Dataset) -> str:
    """The trace a Susi result tracks (``high_latitude``, ``equatorial``)."""
    return str(ds.attrs.get("trace_name", ds.attrs["scenario"]))


def inband_results(results: Sequence[xr.Dataset]) -> dict[str, list[xr.Dataset]]:
    """site -> its results ordered by phase scale (sites in input order)."""
    out: dict[str, list[xr.Dataset]] = {}
    for res in results:
        out.setdefault(site(res), []).append(res)
    return {s: sorted(v, key=phase_scale) for s, v in out.items()}


def lowest_verdict(res: xr.Dataset, trackers: Sequence[str] = INBAND_TRACKERS) -> tuple[str, str]:
    """(tracker with the lowest mean discriminator jitter, verdict text): ``lowest`` when its paired 95% interval to every other
    tracker lies below 0, else ``lowest mean, tied with ...`` naming the trackers whose interval includes 0."""
    trs = [t for t in trackers if has_jitter(res, t)]
    if not trs:
        return "", ""
    label = tracker_labels(res)
    best = min(trs, key=lambda t: float(np.mean(trial_jitter(res, t))))
    ties = [t for t in trs if t != best and paired(trial_jitter(res, best), trial_jitter(res, t))[2] >= 0]
    if ties:
        return best, f"{label.get(best, best)} lowest mean, tied with {', '.join(label.get(t, t) for t in ties)} (paired interval includes 0)"
    return best, f"{label.get(best, best)} lowest (every paired interval below 0)"


def inband_long(results: Sequence[xr.Dataset]) -> pd.DataFrame:
    """One row per site x scale x tracker: jitter with 95% intervals and the paired differences to the PLL and the AKF."""
    rows = []
    for s, group in inband_results(results).items():
        for res in group:
            label = tracker_labels(res)
            best, text = lowest_verdict(res)
            for tr in INBAND_TRACKERS:
                if not has_jitter(res, tr):
                    continue
                row = {"site": s, "scenario": res.attrs["scenario"], "experiment": res.attrs.get("experiment", ""), "data": short_source(res),
                       "phase_scale": phase_scale(res), "tracker": tr, "label": label.get(tr, tr), "trials": int(res["n_trials"])}
                for metric in METRICS:
                    v = trial_jitter(res, tr, metric)
                    row.update(dict(zip((f"{metric}_jitter_rad", f"{metric}_ci95_lo", f"{metric}_ci95_hi"), ci(v))))
                    for other, key in ((REFERENCE, "pll"), (AKF, "akf")):
                        d = paired(v, trial_jitter(res, other, metric)) if tr != other and has_jitter(res, other) else (np.nan,) * 3
                        row.update(dict(zip((f"{metric}_minus_{key}_rad", f"{metric}_minus_{key}_ci95_lo", f"{metric}_minus_{key}_ci95_hi"), d)))
                row.update({"lowest": best == tr, "verdict": text})
                rows.append(row)
    return pd.DataFrame(rows)


def inband_verdicts(long: pd.DataFrame) -> pd.DataFrame:
    """One row per site x scale: each tracker's discriminator jitter, the paired differences and the verdict."""
    rows = []
    for (s, scale), g in long.groupby(["site", "phase_scale"], sort=False):
        g = g.set_index("tracker")
        row = {"site": s, "phase scale": f"{scale:g}", "data": g["data"].iloc[0], "trials": int(g["trials"].iloc[0])}
        for tr in INBAND_TRACKERS:
            if tr in g.index:
                r = g.loc[tr]
                row[f"{r.label} [rad]"] = fmt_ci(r.discriminator_jitter_rad, r.discriminator_ci95_lo, r.discriminator_ci95_hi)
        for a, b, key in ((AKF, REFERENCE, "pll"), (SAKF, REFERENCE, "pll"), (SAKF, AKF, "akf")):
            if a in g.index and b in g.index:
                r = g.loc[a]
                row[f"{r.label} minus {g.loc[b].label} [rad]"] = fmt_ci(r[f"discriminator_minus_{key}_rad"], r[f"discriminator_minus_{key}_ci95_lo"],
                                                                     r[f"discriminator_minus_{key}_ci95_hi"])
        row["lowest discriminator jitter"] = g["verdict"].iloc[0]
        rows.append(row)
    return pd.DataFrame(rows)


def inband_grid(long: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for r in long.itertuples():
        row = {"site": r.site, "phase scale": f"{r.phase_scale:g}", "data": r.data, "tracker": r.label, "trials": r.trials}
        for metric in METRICS:
            row[f"{METRIC_TEXT[metric]} [rad]"] = fmt_ci(getattr(r, f"{metric}_jitter_rad"), getattr(r, f"{metric}_ci95_lo"), getattr(r, f"{metric}_ci95_hi"))
            row[f"{METRIC_TEXT[metric]} minus PLL [rad]"] = fmt_ci(getattr(r, f"{metric}_minus_pll_rad"), getattr(r, f"{metric}_minus_pll_ci95_lo"),
                                                                   getattr(r, f"{metric}_minus_pll_ci95_hi"))
        rows.append(row)
    return pd.DataFrame(rows)


def inband_note(results: Sequence[xr.Dataset]) -> str:
    return ("In-band strength (pre-declared reading): the scintillation PHASE of each scenario's trace multiplied by the phase scale "
            "(scenario option trace.phase_scale), its amplitude unchanged; each scaled scenario draws the unscaled one's noise, clock and "
            f"initial-phase realisations, so only the phase differs. Scale 1 is the {CHAPTER} run of the unscaled scenario, the others the "
            f"{INBAND} run. Verdict: the tracker with the lowest mean discriminator jitter; 'lowest' when its paired 95% interval to each "
            "other tracker lies below 0, 'tied' naming the trackers whose interval includes 0. " + _jitter_method(results[0]) + " "
            + _scenario_notes(results))


@table("susi_table_inband", ["table_inband", "table_inband_verdict", "table_inband_long"], paper=PAPER, section=SECTION, inputs=_inband_inputs,
       surrogate=_inband_surrogate)
def susi_table_inband(*results: xr.Dataset) -> dict:
    """PLL, AKF PLL and SAKF PLL jitter against the strength of the scintillation phase (scaled 0.1-2), and which is lowest."""
    long = inband_long(results)
    note = inband_note(results)
    title = f"Susi et al. 2014: jitter against the strength of the scintillation phase (in-band sweep){_data_title(results)}"
    return {
        "table_inband": (inband_grid(long), title, note),
        "table_inband_verdict": (inband_verdicts(long), title + ": lowest discriminator jitter per scale", note),
        "table_inband_long": (long, title + ", long form", note),
    }
