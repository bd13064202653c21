"""Susi 2014 readings: the AKF's bandwidth per Q term (q_jerk sweep) and the in-band strength option (trace.phase_scale)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from scintrack.experiments.scenario import simulate
from scintrack.experiments.susi_akf_bandwidth import bandwidths
from scintrack.experiments.traces import scenario_trace
from scintrack.products.tables.susi_2014 import lowest_verdict, qjerk_meeting
from scintrack.settings import TrackingSettings
from scintrack.trackers import registry
from scintrack.trackers.base import TrackerContext

TS = 0.001
N = 30_000  # impulse-response samples: 30 s, beyond the slowest loop's (1.5 Hz, second order) decay
TRACKING = {"amplitude": 1.0, "cn0_dbhz": 45.0, "p0_diag": [0.25, 1.0, 100.0], "q_jerk_hz2_s3": 0.01}


def _akf(q_jerk: float, clock: str = "ocxo", cn0: float = 45.0):
    context = TrackerContext(scenario={"clock": clock, "cn0_dbhz": cn0}, tracking=TRACKING, ts=TS)
    return registry.build("x", {"type": "susi_akf", "discriminator": "atan2", "q_jerk_hz2_s3": q_jerk}, context)


def test_bandwidth_terms_follow_the_third_order_loop_theory():
    """q_jerk only: a third-order loop driven by jerk noise has omega_0^6 = q / R, so 100 x q_jerk widens it by 100^(1/6);
    oscillator only: the rate state is undriven (gain 0) and the bandwidth does not depend on q_jerk; the whole Q is at
    least as wide as either part; at the shared q_jerk the OCXO at 45 dB-Hz gives the 4.5-Hz loop of docs/REPRODUCTION.md."""
    lo, hi = bandwidths(_akf(1e-3), n=N), bandwidths(_akf(1e-1), n=N)
    ratio = hi["q_jerk"][0] / lo["q_jerk"][0]
    assert abs(ratio / 100 ** (1 / 6) - 1) < 0.02, ratio
    assert abs(lo["oscillator"][2][2]) < 1e-12 and abs(hi["oscillator"][0] / lo["oscillator"][0] - 1) < 1e-9
    for b in (lo, hi):
        assert b["both"][0] >= max(b["oscillator"][0], b["q_jerk"][0]) - 1e-9
        assert all(abs(v[0] / v[1] - 1) < 0.03 for v in b.values())  # discrete vs continuous closed form (Bn Ts << 1)
    today = bandwidths(_akf(0.01), n=N)["both"][0]
    assert 4.4 < today < 4.6, today


def _trace(n: int = 3000) -> xr.Dataset:
    t = np.arange(n) * TS
    rng = np.random.default_rng(4)
    rho = 1.0 + 0.1 * np.sin(2 * np.pi * 0.3 * t)
    theta = np.cumsum(rng.normal(0.0, 0.01, n)) + 0.5 * np.sin(2 * np.pi * 0.7 * t)
    return xr.Dataset({"amplitude": (("band", "time"), rho[None]), "phase": (("band", "time"), theta[None])},
                      coords={"band": ["L1"], "time": t}, attrs={"event": "x", "source": "surrogate"})


@pytest.mark.parametrize("scale", [0.25, 2.0])
def test_phase_scale_scales_the_tracked_phase_and_keeps_amplitude_and_noise(scale):
    """trace.phase_scale multiplies the tracked scintillation phase (referenced to its first sample) and nothing else: the
    amplitude, the dynamics, the clock and the thermal noise of a scenario with realisations_of are those of the unscaled one."""
    base = {"duration_s": 1.0, "ts": TS, "cn0_dbhz": 45.0, "clock": "ocxo", "scintillation_model": "trace", "segments": [],
            "trace": {"name": "x", "fit_s": 0.0}}
    scaled = {**base, "trace": {**base["trace"], "phase_scale": scale}, "realisations_of": "base"}
    ds = _trace()
    (rho0, th0), _, _ = scenario_trace(ds, base, TS)
    (rho1, th1), _, _ = scenario_trace(ds, scaled, TS)
    np.testing.assert_array_equal(rho1, rho0)
    np.testing.assert_allclose(th1, scale * th0, rtol=1e-12, atol=1e-12)
    (_, th_one), _, _ = scenario_trace(ds, {**base, "trace": {**base["trace"], "phase_scale": 1.0}}, TS)
    np.testing.assert_array_equal(th_one, th0)  # scale 1 is the scenario itself, bit for bit
    tracking = TrackingSettings.from_params({"amplitude": 1.0, "cn0_dbhz": 45.0, "fd0_hz": 100.0, "fr_hz_s": 0.5})
    kw = dict(seed=3, ts=TS, nspa=1, warmup_s=0.0, trials=[0, 1])
    r0 = simulate("base", base, tracking, trace=(rho0, th0), **kw)
    r1 = simulate("scaled", scaled, tracking, trace=(rho1, th1), **kw)
    np.testing.assert_array_equal(r1.theta_d, r0.theta_d)
    np.testing.assert_array_equal(r1.rho_s, r0.rho_s)
    np.testing.assert_allclose(r1.theta_s, scale * r0.theta_s, rtol=1e-12, atol=1e-12)
    # the same thermal noise: y minus the noise-free prompt is identical
    clean0 = r0.rho_s * np.exp(1j * (r0.theta_d + r0.theta_s))
    clean1 = r1.rho_s * np.exp(1j * (r1.theta_d + r1.theta_s))
    np.testing.assert_allclose(r1.y - clean1, r0.y - clean0, atol=1e-12)


def test_phase_scale_is_validated():
    from scintrack.config import load_config, validate_config
    from scintrack.errors import ConfigError

    config = load_config(["config/config.yaml"])
    config["scenarios"]["susi_high_latitude_ph0.5"]["trace"]["phase_scale"] = -1.0
    with pytest.raises(ConfigError, match="phase_scale"):
        validate_config(config, "workflow/schemas/config.schema.yaml")


def test_meeting_point_of_the_qjerk_sweep():
    """A sign change of the paired difference is located by linear interpolation in log q_jerk; an interval that includes 0 is
    a meeting; no sign change names the closest value."""
    def long(d, vs):
        q = [1e-4, 1e-3, 1e-2, 1e-1, 1.0]
        return pd.DataFrame({"scenario": "s", "q_jerk_hz2_s3": q, "discriminator_minus_pll_rad": d, "discriminator_vs_pll": vs})

    text = qjerk_meeting(long([0.3, 0.2, 0.1, -0.1, -0.2], ["above PLL"] * 3 + ["below PLL"] * 2), "s")
    assert "between q_jerk = 0.01 and 0.1" in text and "about 0.032" in text
    assert "at q_jerk = 0.1 " in qjerk_meeting(long([0.3, 0.2, 0.1, 0.0, -0.2], ["above PLL"] * 3 + ["meets PLL (interval includes 0)", "below PLL"]), "s")
    assert "closest at q_jerk = 1 " in qjerk_meeting(long([0.5, 0.4, 0.3, 0.2, 0.05], ["above PLL"] * 5), "s")


def _result(jitter: dict[str, np.ndarray]) -> xr.Dataset:
    names = list(jitter)
    v = np.stack([np.repeat(jitter[n][:, None], 3, axis=1) for n in names])  # (tracker, trial, window)
    return xr.Dataset({"jitter_discriminator": (("tracker", "trial", "window"), v)},
                      coords={"tracker": names, "trial": np.arange(v.shape[1]), "window": [30.0, 90.0, 150.0]},
                      attrs={"steady_state_start_s": 0.0, "tracker_labels": json.dumps({n: n.upper() for n in names})})


def test_lowest_verdict_uses_paired_intervals():
    """A common per-trial offset cancels in the paired difference: a tracker 0.001 rad below another in every trial is
    lowest although the unpaired intervals overlap; equal jitter is a tie."""
    rng = np.random.default_rng(0)
    common = rng.normal(0.15, 0.02, 40)
    res = _result({"susi_pll": common, "susi_akf": common + 0.01, "susi_sakf": common - 0.001 + rng.normal(0, 1e-5, 40)})
    best, text = lowest_verdict(res)
    assert best == "susi_sakf" and text.endswith("lowest (every paired interval below 0)")
    res = _result({"susi_pll": common, "susi_akf": common + 0.01, "susi_sakf": common + rng.normal(0, 1e-3, 40)})
    best, text = lowest_verdict(res)
    assert "tied with" in text
