"""Scintillation indices of a Susi 2014 scenario, as its Figs. 3 and 6 show them.

The chapter plots S4 and Phi60 recorded by a Septentrio ISMR.  We compute,
over consecutive ``window_s`` (60 s) windows of the part that is tracked:

* **truth** (from the noise-free trace): S4 of the detrended intensity
  ``rho^2`` (:func:`scintrack.estimators.s4.detrended_s4`) and Phi60 of the
  0.1-Hz high-passed scintillation phase
  (:func:`scintrack.estimators.sigma_phi.sigma_phi_windows`, zero-phase);
* **receiver** (one noise realisation, trial ``figure_trial``): S4 of the
  prompt intensity with the thermal-noise correction, and Phi60 of the
  carrier phase of the monitoring loop (``indices.tracker``, the 15-Hz PLL)
  with the known geometric dynamics and clock removed (an ISMR's
  geometry-free carrier phase), high-passed causally like a real-time
  monitor (its first minutes are the filter's transient, as in the
  chapter's Fig. 3);

and, on a 0.1-s grid, Phi3 (:func:`~scintrack.estimators.sigma_phi.phi3_sliding`,
3-s window) and the power-law strength T and slope p over 3-s windows
(:func:`scintrack.estimators.power_law.estimate_power_law`) of the true
scintillation phase: what the SAKF's scintillation block would see without
tracking noise.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from ..estimators.power_law import estimate_power_law
from ..estimators.s4 import detrended_s4
from ..estimators.sigma_phi import detrend_phase, phi3_sliding, sigma_phi_windows
from ..trackers import registry
from ..trackers.base import TrackerContext
from .scenario import acquisition, effective_tracking, simulate

GRID_S = 0.1  # time step of the Phi3 / T / p series


def scenario_indices(
    *, scenario_name: str, scenario: Mapping[str, Any], trace: tuple[np.ndarray, np.ndarray], tracker_name: str, tracker_spec: Mapping[str, Any],
    tracking: Mapping[str, Any], seed: int, ts: float, trial: int, window_s: float, phi3_window_s: float, detrend_hz: float,
    fit_band_hz: Sequence[float] = (0.5, 5.0),
) -> xr.Dataset:
    rho, theta = trace
    tracking = effective_tracking(scenario, tracking)
    real = simulate(scenario_name, scenario, tracking, seed=seed, ts=ts, nspa=1, warmup_s=0.0, trials=[trial], trace=trace)
    context = TrackerContext(scenario=scenario, tracking=tracking.given(), ts=ts)
    out = registry.build(tracker_name, tracker_spec, context).run(real.y, acquisition(real, tracking))
    t_w, s4_true = detrended_s4(real.rho_s[0] ** 2, ts, window_s, detrend_hz)
    _, s4_rx = detrended_s4(np.abs(real.y[0]) ** 2, ts, window_s, detrend_hz, noise_power=real.noise_power)
    _, phi60_true = sigma_phi_windows(real.theta_s[0], ts, window_s, detrend_hz)
    _, phi60_rx = sigma_phi_windows(out.theta_d[0] - real.theta_d[0], ts, window_s, detrend_hz, causal=True)
    step = max(int(round(GRID_S / ts)), 1)
    phi3 = phi3_sliding(real.theta_s[0], ts, phi3_window_s, detrend_hz)[::step]
    t_tp, T, p = estimate_power_law(detrend_phase(real.theta_s[0], ts, detrend_hz), ts, phi3_window_s, fit_band_hz[0], fit_band_hz[1], step_s=1.0)
    return xr.Dataset(
        {
            "s4_true": (("window",), s4_true, {"long_name": f"S4 of the detrended intensity over {window_s:g} s (noise-free trace)", "units": "1"}),
            "phi60_true": (("window",), phi60_true, {"long_name": f"sigma_phi over {window_s:g} s, 0.1-Hz high-pass (noise-free trace)", "units": "rad"}),
            "s4_receiver": (("window",), s4_rx, {"long_name": "S4 from the prompts, thermal noise removed", "units": "1"}),
            "phi60_receiver": (("window",), phi60_rx, {"long_name": f"sigma_phi of the {tracker_name} carrier phase (dynamics removed, causal high-pass)", "units": "rad"}),
            "phi3_true": (("grid",), phi3, {"long_name": f"Phi3: sigma_phi over the last {phi3_window_s:g} s (causal)", "units": "rad"}),
            "T_true": (("tp_time",), T, {"long_name": "power-law strength at 1 Hz of the scintillation phase", "units": "rad2/Hz"}),
            "p_true": (("tp_time",), p, {"long_name": "power-law slope of the scintillation phase", "units": "1"}),
        },
        coords={
            "window": ("window", t_w, {"units": "s", "long_name": "window centre"}),
            "grid": ("grid", np.arange(phi3.size) * step * ts, {"units": "s"}),
            "tp_time": ("tp_time", t_tp, {"units": "s", "long_name": "end of the 3-s window"}),
        },
        attrs={"scenario": scenario_name, "window_s": window_s, "phi3_window_s": phi3_window_s, "detrend_hz": detrend_hz, "trial": trial,
               "cn0_dbhz": float(scenario.get("cn0_dbhz", tracking.cn0_dbhz)), "ts": ts, "monitor_tracker": tracker_name},
    )
