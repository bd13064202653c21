"""Susi 2014's 1-ms trace scenarios: trace source switch, resampling, clock truth, params, runner metrics."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from scintrack.config import load_config
from scintrack.data.susi_traces import at_rate, trace_file, trace_input, uses_real
from scintrack.experiments.runner import block_mean, merge, run_shard
from scintrack.experiments.scenario import clock_phase, simulate
from scintrack.experiments.traces import scenario_trace
from scintrack.io import hash_object
from scintrack.models import clock as clock_models
from scintrack.pipeline import params as P
from scintrack.pipeline import paths
from scintrack.settings import TrackingSettings

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def config():
    return load_config([REPO / "config" / "config.yaml"])


def _trace(n, ts, seed=0, sigma=1.0):
    """A smooth scintillation phase (two slow sinusoids, amplitude ``sigma`` rad each) and a fading amplitude."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * ts
    theta = sigma * (np.sin(2 * np.pi * 0.2 * t + rng.uniform(0, 6)) + np.sin(2 * np.pi * 0.5 * t + rng.uniform(0, 6)))
    rho = np.abs(1 + 0.3 * np.sin(np.arange(n) * ts * 2.0))
    return xr.Dataset(
        {"amplitude": (("band", "time"), rho[None]), "phase": (("band", "time"), theta[None])},
        coords={"band": ["L1"], "time": np.arange(n) * ts}, attrs={"event": "t", "source": "surrogate"},
    )


def test_the_equatorial_trace_is_real_only_when_configured(config):
    assert not uses_real(config, "equatorial") and not uses_real(config, "high_latitude")
    assert trace_file(config, "equatorial").startswith("data/synthetic/susi_surrogate_equatorial/")
    cfg = copy.deepcopy(config)
    cfg["real_traces"]["sources"] = {"event1": {"path": "/data/jrc/event1.nc"}}
    assert uses_real(cfg, "equatorial") and not uses_real(cfg, "high_latitude")
    assert trace_file(cfg, "equatorial") == "data/traces/real/event1.nc"
    assert trace_input(cfg, "equatorial")["source"] == {"path": "/data/jrc/event1.nc"}
    assert paths.scenario_trace_path(cfg, "susi_high_latitude").startswith("data/synthetic/susi_surrogate_high_latitude/")
    assert paths.scenario_trace_path(cfg, "s4_0.9_tau0_0.1") is None


def test_at_rate_keeps_a_trace_at_its_rate_and_interpolates_another():
    ds = _trace(1000, 0.01)
    rho, theta, source = at_rate(ds, 0.01)
    np.testing.assert_array_equal(theta, ds["phase"].values[0])
    rho1, theta1, _ = at_rate(ds, 0.001)
    assert theta1.size == 9991 and source == "surrogate"
    np.testing.assert_allclose(theta1[::10], ds["phase"].values[0], atol=1e-12)
    np.testing.assert_allclose(theta1[5], 0.5 * (ds["phase"].values[0, 0] + ds["phase"].values[0, 1]), atol=1e-12)


def test_scenario_trace_splits_fit_and_tracked_parts():
    ts = 0.001
    ds = _trace(12_000, ts)
    sc = {"duration_s": 6.0, "trace": {"name": "t", "fit_s": 5.0}, "segments": []}
    (rho, theta), ar, source = scenario_trace(ds, sc, ts)
    assert rho.size == theta.size == 6000 and theta[0] == 0.0
    np.testing.assert_allclose(theta, ds["phase"].values[0, 5000:11000] - ds["phase"].values[0, 5000])
    assert ar is not None and ar.phase.coefs.size >= 1 and source == "surrogate"
    with pytest.raises(ValueError, match="needed"):
        scenario_trace(ds, {**sc, "duration_s": 8.0}, ts)


def test_receiver_clock_is_the_exact_two_state_process():
    """Per-step phase increments of the simulated clock have the variance of the exact Q (rad)."""
    ts, n = 0.001, 20_000
    ph = clock_phase(1, "clk", np.arange(40), n, ts, "tcxo_low")
    q = clock_models.process_noise(clock_models.preset("tcxo_low"), ts, units="rad")
    d2 = np.diff(ph, 2, axis=1)  # second differences remove the frequency walk's mean part
    expected = 2 * q[0, 0] + q[1, 1] * ts**2 - 2 * q[0, 1] * ts  # var(w0_k + (f_k - f_{k-1}) ts - w0_{k-1}) with w correlated
    assert abs(d2.var() / expected - 1) < 0.1, (d2.var(), expected)
    sc = {"duration_s": 1.0, "segments": [], "clock": "tcxo_low"}
    tracking = TrackingSettings.from_params({"amplitude": 1.0, "cn0_dbhz": 45.0, "fd0_hz": 100.0, "fr_hz_s": 0.0})
    with_clock = simulate("x", sc, tracking, seed=3, ts=ts, nspa=1, warmup_s=0.0, trials=[0, 1])
    without = simulate("x", {**sc, "clock": None}, tracking, seed=3, ts=ts, nspa=1, warmup_s=0.0, trials=[0, 1])
    np.testing.assert_allclose(with_clock.theta_d - without.theta_d, clock_phase(3, "scenario/x/clock", np.array([0, 1]), 1000, ts, "tcxo_low"))
    assert with_clock.fd0_hz == 100.0


def test_experiment_params_follow_the_trace_settings(config):
    a = P.experiment(config, "susi_chapter", "susi_high_latitude")
    assert a["ts"] == 0.001 and "surrogate" in a["trace"]
    cfg = copy.deepcopy(config)
    cfg["susi_2014"]["traces"]["high_latitude"]["surrogate"]["s4_l1"] = 0.15
    assert hash_object(P.experiment(cfg, "susi_chapter", "susi_high_latitude")) != hash_object(a)
    for exp, sc in (("susi_chapter", "susi_equatorial"), ("case2_steady_state", "s4_0.9_tau0_0.1")):
        assert hash_object(P.experiment(cfg, exp, sc)) == hash_object(P.experiment(config, exp, sc))
    assert P.susi_scenarios(config) == ["susi_high_latitude", "susi_equatorial", "susi_high_latitude_event", "susi_high_latitude_event_T"]


def test_runner_on_a_trace_scenario_reports_jitter_and_total_phase_errors(config):
    ts = 0.001
    ds = _trace(9000, ts, sigma=1.5)
    sc = {"duration_s": 4.0, "ts": ts, "fd0_hz": 200.0, "fr_hz_s": 0.5, "clock": "ocxo", "scintillation_model": "trace",
          "trace": {"name": "t", "fit_s": 4.0}, "segments": [], "tracking": {"steady_state_start_s": 1.0, "cn0_window": 500}}
    trace, ar, _ = scenario_trace(ds, sc, ts)
    tracking = dict(config["tracking"], jitter_window_s=1.0)
    names = ["susi_pll", "susi_akf", "kf", "akf_ar_trace"]
    shard = run_shard(scenario_name="t", scenario=sc, tracker_names=names, tracker_specs=config["trackers"], tracking=tracking, lut=None,
                      seed=1, ts=ts, nspa=1, warmup_s=0.0, trials=range(3), trace=trace, trace_set=ar)
    res = merge([shard])
    assert res.sizes["time"] == 400 and res.sizes["window"] == 4  # 10-ms blocks, 1-s windows
    np.testing.assert_allclose(res["time"].values[:2], [0.0045, 0.0145])
    jd = res["jitter_discriminator"]
    assert np.isfinite(jd.sel(tracker=["susi_pll", "susi_akf"])).all() and np.isnan(jd.sel(tracker="kf")).all()
    # loops without a scintillation model follow theta_s: small total-phase error, large theta_d error
    assert float(res["steady_rmse_total"].sel(tracker="susi_pll")) < 0.3 < float(res["steady_rmse"].sel(tracker="susi_pll", kind="wrapped"))
    for tr in ("susi_akf", "kf"):
        assert float(res["steady_rmse_total"].sel(tracker=tr)) < float(res["steady_rmse"].sel(tracker=tr, kind="wrapped"))
    assert np.isfinite(res["steady_rmse_total"].sel(tracker="akf_ar_trace"))
    np.testing.assert_allclose(block_mean(np.arange(25.0), 10), [4.5, 14.5])
