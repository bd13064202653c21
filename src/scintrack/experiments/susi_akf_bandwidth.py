"""Susi et al. 2014: where the AKF PLL's steady-state loop bandwidth comes from.

The AKF PLL's process noise (eqs. 4-6) has two sources: the receiver
oscillator (eq. 5 ``S_dphi = f_L1^2 h0 / 2`` on the phase, eq. 6
``S_df = f_L1^2 2 pi^2 h_-2`` on the frequency, rad and Hz) and the
Doppler-jerk PSD ``q_jerk`` on the rate state, which the chapter does not
give.  With R = eq. (10) at the scenario's C/N0 the filter converges to the
fixed gain of the discrete algebraic Riccati equation
(:func:`scintrack.trackers.susi_kf.steady_state_gain`), a third-order loop
whose noise bandwidth is :func:`scintrack.trackers.susi_kf.loop_bandwidth_hz`.

:func:`bandwidth_decomposition` gives that bandwidth for each tracker of the
``q_jerk`` sweep with

* ``both``: the tracker's Q (oscillator + ``q_jerk``);
* ``oscillator``: ``q_jerk = 0`` (the rate state undriven: the gain of the
  rate state is 0 and the loop is of second order);
* ``q_jerk``: the oscillator's PSDs set to 0.

For a third-order loop driven by jerk noise alone the bandwidth grows as
``(q_jerk / R)^(1/6)`` (the loop's natural frequency ``omega_0^6 = q / R`` in
the continuous limit), a property the tests check.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from ..trackers import registry
from ..trackers.base import TrackerContext
from ..trackers.susi_kf import SusiKF, loop_bandwidth_closed_form, loop_bandwidth_hz, steady_state_gain
from .scenario import effective_tracking

#: the Q terms of each bandwidth, in the order of the ``terms`` coordinate
TERMS = ("both", "oscillator", "q_jerk")


def without_oscillator(tracker: SusiKF) -> SusiKF:
    """The same filter with the oscillator's PSDs (eqs. 5-6) set to 0: Q holds the ``q_jerk`` term only."""

    @dataclasses.dataclass
    class NoOscillator(type(tracker)):
        def clock_psd(self) -> tuple[float, float]:
            return 0.0, 0.0

    return NoOscillator(**{f.name: getattr(tracker, f.name) for f in dataclasses.fields(tracker)})


def term_trackers(tracker: SusiKF) -> dict[str, SusiKF]:
    """The filter of each entry of :data:`TERMS`."""
    return {"both": tracker, "oscillator": dataclasses.replace(tracker, q_jerk=0.0), "q_jerk": without_oscillator(tracker)}


def bandwidths(tracker: SusiKF, n: int = 200_000) -> dict[str, tuple[float, float, np.ndarray]]:
    """term -> (discrete noise bandwidth [Hz] from ``n`` samples of the impulse response, continuous closed form [Hz],
    steady-state gain) at the nominal C/N0."""
    out = {}
    for term, trk in term_trackers(tracker).items():
        K = steady_state_gain(trk)
        out[term] = (loop_bandwidth_hz(K, trk.ts, n=n), loop_bandwidth_closed_form(K, trk.ts), K)
    return out


def bandwidth_decomposition(run: Mapping[str, Any]) -> xr.Dataset:
    """Steady-state bandwidth of every AKF tracker of ``run`` (:func:`scintrack.pipeline.params.susi_akf_bandwidth`)
    on each scenario, per Q term (dims scenario, tracker, term), with each tracker's ``q_jerk`` and the scenario's
    oscillator, C/N0 and Ts."""
    names = list(run["tracker_names"])
    scen = list(run["scenarios"])
    bw = np.full((len(scen), len(names), len(TERMS)), np.nan)
    bw_c = np.full_like(bw, np.nan)
    gains = np.full((len(scen), len(names), len(TERMS), 3), np.nan)
    q_jerk = np.full(len(names), np.nan)
    clocks, cn0s, tss = [], [], []
    for i, sc in enumerate(scen):
        scenario, ts = run["scenarios"][sc]["scenario"], float(run["scenarios"][sc]["ts"])
        tracking = effective_tracking(scenario, run["tracking"]).given()
        context = TrackerContext(scenario=scenario, tracking=tracking, ts=ts)
        for j, name in enumerate(names):
            trk = registry.build(name, run["trackers"][name], context)
            q_jerk[j] = trk.q_jerk
            terms = bandwidths(trk)
            for k, term in enumerate(TERMS):
                bw[i, j, k], bw_c[i, j, k], gains[i, j, k] = terms[term]
        clocks.append(str(trk.clock))
        cn0s.append(10.0 * np.log10(trk.nominal_cn0_hz))
        tss.append(ts)
    return xr.Dataset(
        {
            "bandwidth_hz": (("scenario", "tracker", "term"), bw, {"long_name": "noise bandwidth of the steady-state loop, sum(h^2) / (2 Ts)", "units": "Hz"}),
            "bandwidth_closed_form_hz": (("scenario", "tracker", "term"), bw_c, {"long_name": "continuous third-order loop with the same gains", "units": "Hz"}),
            "gain": (("scenario", "tracker", "term", "state"), gains, {"long_name": "steady-state Kalman gain (phase rad, frequency Hz, rate Hz/s per rad)"}),
            "q_jerk_hz2_s3": (("tracker",), q_jerk, {"long_name": "Doppler-jerk PSD of the tracker's Q", "units": "Hz2/s3"}),
            "clock": (("scenario",), np.array(clocks, dtype=object), {"long_name": "receiver oscillator of eqs. (5)-(6)"}),
            "cn0_dbhz": (("scenario",), np.array(cn0s), {"long_name": "C/N0 of R (eq. 10)", "units": "dB-Hz"}),
            "ts": (("scenario",), np.array(tss), {"units": "s"}),
        },
        coords={"scenario": scen, "tracker": names, "term": list(TERMS), "state": ["phase", "frequency", "rate"]},
        attrs={"product": "susi_akf_bandwidth",
               "title": "Susi et al. 2014: steady-state loop bandwidth of the AKF PLL, oscillator and q_jerk terms of Q"},
    )
