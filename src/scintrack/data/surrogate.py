"""The synthetic surrogate of the JRC Hanoi traces (the offline default).

Three events shaped like Vila-Valls 2018, Sec. VI-E (#1 and #2 severe, #3
moderate to strong), each a multi-frequency phase-screen realisation
(:mod:`scintrack.signals.phase_screen`) written in the same canonical format
as a real trace (:mod:`.traces`), so everything downstream treats both alike.
Every file, attribute and title made from it says "surrogate".

The stored phase is detrended like an open-loop-processed scintillation
phase (zero-phase 6th-order Butterworth high-pass at ``detrend_hz``, 0.1 Hz
by default): the screen's scales beyond ~1 km give tens of radians of slow,
TEC-like phase over an event, which the paper's "dynamics-free" traces do not
contain (its PLL errors of 0.1-0.6 rad in Table VI are impossible otherwise:
every tracker follows that slow phase, and it would count as theta_d error).

An event's parameters (``real_traces.surrogate.events.<event>`` plus the
shared screen geometry, sampling, bands and seed) determine its version, so
changing any of them, or the generator, gives a new file.  The parameters and
the version are defined in :mod:`.surrogate_spec` (no numerical imports: the
workflow needs them to build the DAG) and re-exported here.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from ..seeding import rng_for
from ..signals import phase_screen as ps
from .surrogate_spec import GENERATOR, GENERATOR_VERSION, surrogate_params, surrogate_version  # noqa: F401  (defined in surrogate_spec; re-exported here)

MARGIN_S = 20.0  # generated and dropped at both ends (no wrap-around of the periodic screen)


def surrogate_event(params: Mapping[str, Any]) -> xr.Dataset:
    """Generate one event; canonical trace Dataset (band, time) with provenance attributes."""
    ts = params["ts"]
    n_keep = int(round(params["duration_s"] / ts))
    margin = int(round(MARGIN_S / ts))
    n = n_keep + 2 * margin
    geometry = ps.ScreenGeometry(height_m=params["height_m"], drift_m_s=params["drift_m_s"], outer_scale_m=params["outer_scale_m"])
    white = ps.white_spectrum(rng_for(params["seed"], f"surrogate/{params['event']}", 0), n)
    env = ps.envelope([[t + MARGIN_S, g] for t, g in params["profile"]], n, ts)
    strength, index = ps.calibrate(
        white, n, env, ts=ts, geometry=geometry, s4_target=params["s4_l1"], sigma_phi_target=params["sigma_phi_l1"],
        window_s=params["window_s"], margin=margin, detrend_hz=params["detrend_hz"],
    )
    dx = geometry.drift_m_s * ts
    ev = ps.propagate_event(ps.shaped_screen(white, n, dx, index, geometry.outer_scale_m), env, strength, dx, params["bands"], geometry, margin)
    bands = list(params["bands"])
    per = int(round(params["window_s"] / ts))
    s4 = {b: float(ps.window_s4(ev.rho[b] ** 2, per).mean()) for b in bands}
    sig = {b: float(ps.window_sigma_phi(ev.theta[b], ts, per, params["detrend_hz"]).mean()) for b in bands}
    theta = {b: ps.detrend_phase(ev.theta[b], ts, params["detrend_hz"]) for b in bands}
    ds = xr.Dataset(
        {
            "amplitude": (("band", "time"), np.array([ev.rho[b] for b in bands], dtype=np.float32), {"units": "1", "long_name": "SURROGATE scintillation amplitude rho_s (unit mean power)"}),
            "phase": (("band", "time"), np.array([theta[b] for b in bands], dtype=np.float32), {"units": "rad", "long_name": "SURROGATE scintillation phase theta_s (unwrapped, detrended)"}),
            "mean_s4": (("band",), np.array([s4[b] for b in bands]), {"long_name": f"mean of {params['window_s']:g} s window S4", "units": "1"}),
            "mean_sigma_phi": (("band",), np.array([sig[b] for b in bands]), {"long_name": f"mean of {params['window_s']:g} s window sigma_phi (0.1 Hz high-pass)", "units": "rad"}),
        },
        coords={"band": bands, "time": ("time", np.arange(n_keep) * ts, {"units": "s"})},
    )
    ds.attrs.update(
        {
            "event": params["event"],
            "source": "surrogate",
            "title": f"SURROGATE scintillation event {params['event']} (phase screen; not JRC data)",
            "generator": GENERATOR,
            "generator_version": GENERATOR_VERSION,
            "screen_strength_rad": strength,
            "spectral_index": index,
            "phase_detrending": f"zero-phase 6th-order Butterworth high-pass at {params['detrend_hz']:g} Hz",
            "carrier_frequencies_hz": ", ".join(f"{b}={ps.GPS_CARRIERS_HZ[b]:.0f}" for b in bands),
        }
    )
    return ds
