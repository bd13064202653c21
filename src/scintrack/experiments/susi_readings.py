"""Susi et al. 2014, readings U1-U4 of eqs. (7)-(8): the steady-state loop of each reading on each scenario.

The SAKF's process noise adds, every 0.1 s, the scintillation PSDs of eqs. (7)-(8) computed from its on-line
power law ``T f^-p`` (:func:`scintrack.trackers.susi_kf.scintillation_q_psd` gives each reading's formula).
For one reading on one scenario the loop it runs is summarised by the steady-state Kalman gain with those PSDs
held at the reading's own median on-line T and p (median over the time blocks after the steady-state start of
the per-block statistic the experiment records: the median over trials of T, the mean over trials of p and of
the eq. (12) weight w):

* ``K`` solves the discrete Riccati equation with Q = clock + rate + scintillation terms and R = eq. (10) at the
  scenario's C/N0 (:func:`~scintrack.trackers.susi_kf.steady_state_gain`);
* ``bandwidth_hz`` = :func:`~scintrack.trackers.susi_kf.loop_bandwidth_hz` of ``K`` (the declared number);
* ``bandwidth_weighted_hz`` = the same of ``w K`` at the median weight: the loop the eq. (12) weighting leaves
  (a fixed-gain approximation: the weighted filter's own P differs from the Riccati P).

The AKF (``susi_akf``) rows have no scintillation terms (its clock-only loop).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

#: the variables per (scenario, tracker)
VARIABLES = {
    "T_median": ("rad2/Hz", "median over the steady-state time blocks of the median over trials of the on-line T (1 Hz)"),
    "p_median": ("1", "median over the steady-state time blocks of the mean over trials of the on-line p"),
    "weight_median": ("1", "median over the steady-state time blocks of the mean over trials of the eq. (12) weight w"),
    "s_phi": ("rad2/s", "S_dphi,scint of the reading at the median T, p"),
    "s_f": ("Hz2/s", "S_df,scint of the reading at the median T, p"),
    "bandwidth_hz": ("Hz", "noise bandwidth of the steady-state (Riccati) gain K at the median T, p"),
    "bandwidth_weighted_hz": ("Hz", "noise bandwidth of w K at the median weight w"),
}


def steady_median(result: xr.Dataset, var: str, tracker: str) -> float:
    """Median over the time blocks at or after ``steady_state_start_s`` of the per-block ``var`` of ``tracker`` (NaN if none)."""
    if var not in result:
        return np.nan
    v = np.asarray(result[var].sel(tracker=tracker).values, dtype=float)
    t = np.asarray(result["time"].values, dtype=float)
    v = v[(t >= float(result.attrs["steady_state_start_s"])) & np.isfinite(v)]
    return float(np.median(v)) if v.size else np.nan


def reading_loop(tracker: Any, T: float, p: float, weight: float, n: int = 200_000) -> dict[str, float]:
    """The scintillation PSDs of ``tracker``'s reading at (T, p) and the noise bandwidths of its steady-state gain
    (impulse responses of ``n`` epochs, :func:`~scintrack.trackers.susi_kf.loop_bandwidth_hz`)."""
    from ..trackers.susi_kf import loop_bandwidth_hz, steady_state_gain

    if getattr(tracker, "scintillation", False):
        s_phi, s_f = (float(v[0]) for v in tracker.scint_psd(np.array([T]), np.array([p])))
        if not tracker.scintillation_q:
            s_phi = s_f = 0.0
    else:
        s_phi = s_f = 0.0
        weight = 1.0
    K = steady_state_gain(tracker, scint=(s_phi, s_f))
    w = weight if np.isfinite(weight) else 1.0
    return {"s_phi": s_phi, "s_f": s_f, "bandwidth_hz": loop_bandwidth_hz(K, tracker.ts, n=n), "bandwidth_weighted_hz": loop_bandwidth_hz(w * K, tracker.ts, n=n)}


def readings_loops(run: Mapping[str, Any], results: Mapping[str, xr.Dataset], n: int = 200_000) -> xr.Dataset:
    """One row per (scenario, tracker) of ``run["scenarios"]`` (each: ``scenario``, ``tracking``, ``ts``) and
    ``run["trackers"]`` (name -> spec, the Susi KF types), from the experiment result of each scenario (``n``: the
    impulse-response length of :func:`reading_loop`)."""
    from ..trackers import registry
    from ..trackers.base import TrackerContext
    from .scenario import effective_tracking

    names = list(run["trackers"])
    rows = {k: np.full((len(run["scenarios"]), len(names)), np.nan) for k in VARIABLES}
    readings = []
    for i, (sc_name, sc) in enumerate(run["scenarios"].items()):
        res = results[sc_name]
        context = TrackerContext(scenario=sc["scenario"], tracking=effective_tracking(sc["scenario"], sc["tracking"]).given(), ts=float(sc["ts"]))
        for j, name in enumerate(names):
            spec = run["trackers"][name]
            trk = registry.build(name, spec, context)
            T, p, w = (steady_median(res, f"{v}_mean", name) for v in ("T", "p", "weight"))
            vals = {"T_median": T, "p_median": p, "weight_median": w, **reading_loop(trk, T, p, w, n)}
            for k, v in vals.items():
                rows[k][i, j] = v
            if i == 0:
                readings.append(str(spec.get("scintillation_q_reading", "literal")) if spec["type"] == "susi_sakf" else "none")
    ds = xr.Dataset({k: (("scenario", "tracker"), v, {"units": VARIABLES[k][0], "long_name": VARIABLES[k][1]}) for k, v in rows.items()},
                    coords={"scenario": list(run["scenarios"]), "tracker": names, "reading": ("tracker", readings)})
    return ds
