"""Experiments on recorded (real or surrogate) multi-frequency traces, Sec. VI-E.

* :func:`fit_trace_models`: AR models fitted on the first ``fit_s`` seconds of
  each band (amplitude AR(3) with constant, phase AR(p) with p from Table I
  for the region of the fitting segment's S4), the models the AR-based
  trackers use on the rest of the trace ("we use one portion of the real
  scintillation time series for AR model fitting, and then process the rest").
* :func:`trace_diagnostics`: S4 over time (Fig. 12) and the PACF of severe,
  moderate and low segments (Figs. 13-14).
* :func:`static_experiment`: dynamics-free scintillation tracking with the
  AEKF-AR (Fig. 11, Table V): theta_d = 0 and known, the filter estimates
  rho_s and theta_s from noisy prompts.  The I/Q measurement model is
  invariant under (rho, theta) -> (-rho, theta + pi); nothing in eqs. (9)-(14)
  keeps rho_s > 0, and in deep fades the EKF does cross to the mirror
  solution.  We report the plain errors (theta wrapped to (-pi, pi], as in
  Table III) and, as diagnostics, |rho_hat| and the unwrapped phase error.
* :func:`dynamics_experiment`: the trace on top of the aeronautical dynamics,
  every tracker (Fig. 15, Tables VI and VIII).
* :func:`scenario_trace`: the trace of a ``scintillation_model: trace``
  scenario (Susi 2014's 1-ms cases): its L1 band at the scenario's Ts, the AR
  models fitted on its first ``trace.fit_s`` seconds (for ``design: trace``
  trackers) and the ``duration_s`` seconds after them, the scintillation the
  experiment tracks.

The evaluation segment is the ``eval_s`` seconds after the fitting segment;
its phase is referenced to its first sample (open-loop processing leaves an
arbitrary constant).  Trials differ in thermal noise (and, with dynamics, in
the initial phase); the trace itself is the same in every trial.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from ..estimators.s4 import s4_batch
from ..models.ar import ArModel, ScintillationAR, fit_ar, pacf_with_bound
from ..models.lut import AMPLITUDE_ORDER, TABLE_I_PHASE_ORDER
from ..models.regions import region_of
from ..trackers import registry
from ..trackers.base import TrackerContext
from .metrics import mean_with_ci, wrap
from .runner import run_shard, tracker_labels
from .scenario import acquisition, effective_tracking, simulate

MAX_LAGS = 3


def segment(ds: xr.Dataset, band: str, start_s: float, length_s: float, ts: float) -> tuple[np.ndarray, np.ndarray]:
    i0, n = int(round(start_s / ts)), int(round(length_s / ts))
    rho = ds["amplitude"].sel(band=band).values[i0 : i0 + n].astype(float)
    theta = ds["phase"].sel(band=band).values[i0 : i0 + n].astype(float)
    if rho.size < n:
        raise ValueError(f"event {ds.attrs.get('event')}: {band} has {ds.sizes['time'] * ts:g} s, {start_s + length_s:g} s needed (real_traces.fit_s + eval_s)")
    return rho, theta - theta[0]


def fit_trace_models(ds: xr.Dataset, *, fit_s: float, ts: float) -> xr.Dataset:
    """AR models of every band of one event, fitted on its first ``fit_s`` seconds."""
    bands = list(ds["band"].values)
    beta = np.zeros((len(bands), MAX_LAGS))
    gamma = np.zeros((len(bands), MAX_LAGS))
    kappa, s2_th, s2_rho, s4_fit, p_order = (np.zeros(len(bands)) for _ in range(5))
    for j, band in enumerate(bands):
        rho, theta = segment(ds, band, 0.0, fit_s, ts)
        s4_fit[j] = float(s4_batch(rho, 0.0))
        p = TABLE_I_PHASE_ORDER[region_of(max(s4_fit[j], 1e-6))]
        ph = fit_ar(theta, p, "n")
        am = fit_ar(rho, AMPLITUDE_ORDER, "c")
        beta[j, :p], gamma[j, :AMPLITUDE_ORDER] = ph.coefs, am.coefs
        kappa[j], s2_th[j], s2_rho[j], p_order[j] = am.const, ph.sigma2, am.sigma2, p
    return xr.Dataset(
        {
            "beta": (("band", "lag"), beta, {"long_name": "AR(p) phase coefficients (zero-padded)"}),
            "gamma": (("band", "lag"), gamma, {"long_name": "AR(3) amplitude coefficients"}),
            "kappa": (("band",), kappa),
            "sigma2_theta": (("band",), s2_th, {"units": "rad2"}),
            "sigma2_rho": (("band",), s2_rho),
            "phase_order": (("band",), p_order.astype(int)),
            "s4_fit": (("band",), s4_fit, {"long_name": "S4 of the fitting segment"}),
        },
        coords={"band": bands, "lag": np.arange(1, MAX_LAGS + 1)},
        attrs={"event": ds.attrs["event"], "source": ds.attrs["source"], "fit_s": fit_s},
    )


def trace_ar_set(models: xr.Dataset, band: str) -> ScintillationAR:
    """The phase/amplitude AR models of one band, as the trackers use them."""
    m = models.sel(band=band)
    p = int(m["phase_order"])
    return ScintillationAR(
        phase=ArModel(m["beta"].values[:p].copy(), 0.0, float(m["sigma2_theta"])),
        amplitude=ArModel(m["gamma"].values[:AMPLITUDE_ORDER].copy(), float(m["kappa"]), float(m["sigma2_rho"])),
        s4=float(m["s4_fit"]),
        label=f"{models.attrs['event']} {band}: AR({p})/AR(3) fitted on the first {models.attrs['fit_s']:g} s",
    )


def scenario_trace(ds: xr.Dataset, scenario: Mapping[str, Any], ts: float) -> tuple[tuple[np.ndarray, np.ndarray], ScintillationAR, str]:
    """((rho, theta) to track, AR models of the fitting part, source) of a trace scenario.

    ``trace.phase_scale`` (default 1) multiplies the trace's phase, amplitude unchanged, before the
    fit and the tracked segment are cut: the same event with its phase scintillation ``phase_scale``
    times as strong (Susi's in-band strength sweep; the trace file itself is the unscaled one).
    """
    from ..data.susi_traces import at_rate

    rho, theta, source = at_rate(ds, ts)
    scale = float(scenario["trace"].get("phase_scale", 1.0))
    if scale != 1.0:
        theta = theta * scale
    fit_s, duration_s = float(scenario["trace"]["fit_s"]), float(scenario["duration_s"])
    name = str(ds.attrs.get("event", scenario["trace"]["name"]))
    one = xr.Dataset(
        {"amplitude": (("band", "time"), rho[None, :]), "phase": (("band", "time"), theta[None, :])},
        coords={"band": ["L1"], "time": np.arange(rho.size) * ts}, attrs={"event": name, "source": source},
    )
    if fit_s > 0:
        models = fit_trace_models(one, fit_s=fit_s, ts=ts)
        ar = trace_ar_set(models, "L1")
    else:
        ar = None
    return segment(one, "L1", fit_s, duration_s, ts), ar, source


def sliding_s4(rho: np.ndarray, ts: float, window_s: float, step_s: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """S4 over a sliding window with the tracker issue's estimator (noise-free trace: no correction)."""
    w, step = int(round(window_s / ts)), int(round(step_s / ts))
    starts = np.arange(0, rho.size - w + 1, step)
    idx = starts[:, None] + np.arange(w)[None, :]
    return (starts + w / 2) * ts, s4_batch(rho[idx], 0.0, axis=-1)


def trace_diagnostics(events: Mapping[str, xr.Dataset], *, ts: float, window_s: float, pacf_lags: int, segment_s: float) -> xr.Dataset:
    """S4(t) of every event and band; PACF of the L1 segments nearest the three regions."""
    names = list(events)
    bands = list(events[names[0]]["band"].values)
    t_s4, rows = None, []
    for name in names:
        per_band = []
        for band in bands:
            t_s4, s4 = sliding_s4(events[name]["amplitude"].sel(band=band).values.astype(float), ts, window_s)
            per_band.append(s4)
        rows.append(per_band)
    n = min(len(r[0]) for r in rows)
    s4_t = np.array([[b[:n] for b in r] for r in rows])
    # segments: non-overlapping windows of segment_s on L1, the most severe, a moderate and the lowest
    seg = int(round(segment_s / ts))
    cands = []
    for e, name in enumerate(names):
        rho = events[name]["amplitude"].sel(band=bands[0]).values.astype(float)
        for k in range(rho.size // seg):
            r = rho[k * seg : (k + 1) * seg]
            cands.append((float(s4_batch(r, 0.0)), e, k))
    cands.sort()
    picks = {"severe": cands[-1], "moderate": min(cands, key=lambda c: abs(c[0] - 0.45)), "low": cands[0]}
    pacf_v = np.zeros((3, 2, pacf_lags + 1))
    pacf_b = np.zeros_like(pacf_v)
    seg_s4, seg_event, seg_start = [], [], []
    for r, (_region, (s4v, e, k)) in enumerate(picks.items()):
        ds = events[names[e]]
        for c, comp in enumerate(("amplitude", "phase")):
            x = ds[comp].sel(band=bands[0]).values[k * seg : (k + 1) * seg].astype(float)
            pacf_v[r, c], pacf_b[r, c] = pacf_with_bound(x, pacf_lags)
        seg_s4.append(s4v)
        seg_event.append(names[e])
        seg_start.append(k * segment_s)
    return xr.Dataset(
        {
            "s4": (("event", "band", "s4_time"), s4_t, {"long_name": f"S4 over a sliding {window_s:g} s window", "units": "1"}),
            "pacf": (("segment", "component", "lag"), pacf_v),
            "pacf_bound": (("segment", "component", "lag"), pacf_b, {"long_name": "95% band half-width"}),
            "segment_s4": (("segment",), np.array(seg_s4)),
            "segment_event": (("segment",), np.array(seg_event, dtype=object)),
            "segment_start_s": (("segment",), np.array(seg_start)),
        },
        coords={"event": names, "band": bands, "s4_time": ("s4_time", t_s4[:n] if t_s4 is not None else [], {"units": "s"}),
                "segment": list(picks), "component": ["amplitude", "phase"], "lag": np.arange(pacf_lags + 1)},
        attrs={"segment_s": segment_s, "source": events[names[0]].attrs["source"]},
    )


def static_experiment(
    ds: xr.Dataset, models: xr.Dataset, *, tracker_name: str, tracker_spec: Mapping[str, Any], tracking: Mapping[str, Any],
    seed: int, ts: float, fit_s: float, eval_s: float, trials: Sequence[int],
) -> xr.Dataset:
    """AEKF-AR tracking rho_s and theta_s of every band with theta_d = 0 known (Table V, Fig. 11)."""
    bands = list(ds["band"].values)
    event = ds.attrs["event"]
    scenario = {"duration_s": eval_s, "segments": []}
    tracking = effective_tracking(scenario, tracking)
    n = int(round(eval_s / ts))
    rms = {k: np.zeros((len(bands), len(trials))) for k in ("rho", "theta", "abs_rho", "theta_unwrapped")}
    ex = {k: np.zeros((len(bands), n)) for k in ("rho_true", "rho_hat", "theta_true", "theta_hat")}
    for j, band in enumerate(bands):
        trace = segment(ds, band, fit_s, eval_s, ts)
        real = simulate(f"trace/{event}/{band}/static", scenario, tracking, seed=seed, ts=ts, nspa=1, warmup_s=0.0, trials=trials, trace=trace, dynamics=False)
        context = TrackerContext(scenario=scenario, tracking=tracking.given(), lut=None, ts=ts, trace_set=trace_ar_set(models, band))
        tracker = registry.build(tracker_name, tracker_spec, context)
        tracker.request(("theta_s", "rho_s"))
        out = tracker.run(real.y, acquisition(real, tracking, static=True))
        theta_hat = out.theta_d + out.extras["theta_s"]  # theta_d stays 0: the scintillation phase estimate
        rms["rho"][j] = np.mean((out.extras["rho_s"] - real.rho_s) ** 2, axis=1)
        rms["abs_rho"][j] = np.mean((np.abs(out.extras["rho_s"]) - real.rho_s) ** 2, axis=1)
        rms["theta"][j] = np.mean(wrap(theta_hat - real.theta_s) ** 2, axis=1)
        rms["theta_unwrapped"][j] = np.mean((theta_hat - real.theta_s) ** 2, axis=1)
        ex["rho_true"][j], ex["rho_hat"][j] = real.rho_s[0], out.extras["rho_s"][0]
        ex["theta_true"][j], ex["theta_hat"][j] = real.theta_s[0], theta_hat[0]
    data = {}
    for k, long in (("rho", "amplitude"), ("theta", "phase, error wrapped to (-pi, pi]"), ("abs_rho", "amplitude, |rho_hat| (sign ambiguity removed)"), ("theta_unwrapped", "phase, unwrapped error")):
        ms, lo, hi = mean_with_ci(rms[k], axis=-1)
        data[f"rmse_{k}"] = (("band",), np.sqrt(ms), {"long_name": f"RMSE of the scintillation {long} over the evaluation segment"})
        data[f"rmse_{k}_lo"] = (("band",), np.sqrt(lo))
        data[f"rmse_{k}_hi"] = (("band",), np.sqrt(hi))
        data[f"ms_{k}"] = (("band", "trial"), rms[k])
    for k, v in ex.items():
        data[f"example_{k}"] = (("band", "time"), v)
    return xr.Dataset(
        data, coords={"band": bands, "trial": np.asarray(list(trials)), "time": ("time", np.arange(n) * ts, {"units": "s"})},
        attrs={"event": event, "source": ds.attrs["source"], "fit_s": fit_s, "eval_s": eval_s, "cn0_dbhz": tracking.cn0_dbhz,
               "tracker_labels": tracker_labels([tracker_name], {tracker_name: tracker_spec})},
    )


def dynamics_experiment(
    ds: xr.Dataset, models: xr.Dataset, *, tracker_names: Sequence[str], tracker_specs: Mapping[str, Mapping[str, Any]],
    tracking: Mapping[str, Any], lut: xr.Dataset | None, seed: int, ts: float, fit_s: float, eval_s: float, rmse_start_s: float,
    trials: Sequence[int],
) -> xr.Dataset:
    """Every tracker on the trace plus the aeronautical dynamics, per band (Fig. 15, Tables VI, VIII)."""
    from .runner import merge

    bands = list(ds["band"].values)
    event = ds.attrs["event"]
    trk = dict(tracking, steady_state_start_s=rmse_start_s)
    per_band = []
    for band in bands:
        shard = run_shard(
            scenario_name=f"trace/{event}/{band}", scenario={"duration_s": eval_s, "segments": []}, tracker_names=list(tracker_names),
            tracker_specs=tracker_specs, tracking=trk, lut=lut, seed=seed, ts=ts, nspa=1, warmup_s=0.0, trials=trials,
            trace=segment(ds, band, fit_s, eval_s, ts), trace_set=trace_ar_set(models, band),
        )
        per_band.append(merge([shard]).drop_vars(["s4_true", "tau0_true"]))
    out = xr.concat(per_band, dim=xr.DataArray(bands, dims="band", name="band"), coords="minimal", compat="override")
    out.attrs.update({"event": event, "source": ds.attrs["source"], "fit_s": fit_s, "eval_s": eval_s, "rmse_start_s": rmse_start_s,
                      "tracker_labels": tracker_labels(list(tracker_names), tracker_specs)})
    return out
