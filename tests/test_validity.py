"""Values outside a model's validity are refused or clamped visibly (scintrack.validity, the CSM range,
the AR-grid look-ups, the "not estimable" S4 and the AEKF-AR's hold of the last estimable S4)."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import xarray as xr
from conftest import REPO

from scintrack.config import load_config, validate_config
from scintrack.errors import ConfigError
from scintrack.estimators.s4 import StreamingS4, estimable_fraction, s4_batch, s4_corrected, s4_index
from scintrack.experiments.scenario import simulate
from scintrack.models.ar import ScintillationAR
from scintrack.settings import TrackingSettings
from scintrack.signals.csm import S4_MAX, Segment, generate_csm, generate_csm_profile
from scintrack.trackers import blocks
from scintrack.trackers.aekf_ar import AEKFAR
from scintrack.trackers.base import TrackerContext, TrackInit
from scintrack.trackers.kf import AKFAR

SCHEMA = REPO / "workflow" / "schemas" / "config.schema.yaml"
TS = 0.01


@pytest.fixture(scope="module")
def config():
    return load_config([REPO / "config" / "config.yaml"])


def _refused(config, change) -> str:
    cfg = copy.deepcopy(config)
    change(cfg)
    with pytest.raises(ConfigError) as err:
        validate_config(cfg, SCHEMA)
    msg = str(err.value)
    assert "\n" not in msg
    return msg


# --- the CSM realises S4 <= 1 and refuses more ------------------------------------------------


@pytest.mark.parametrize("s4", [0.2, 0.4, 0.6, 0.8, 1.0])
def test_csm_realises_the_requested_s4(s4):
    """8 trials x 300 s at tau0 = 0.1 s, as the pipeline generates (Nspa = 8, averaged output, warm-up):
    the trial-mean S4 of |z|^2 within 4 standard errors of the mean (the trial-to-trial spread; about
    0.001 at S4 = 0.2 to 0.005 at S4 = 1: each 300-s trial holds ~3000 decorrelation times) of the request.
    A wrong Rice K (e.g. K from m instead of from the Nakagami match, or the m clamp at another S4) is off
    by far more."""
    real = generate_csm(seed=3, name="validity", trials=range(8), n_epochs=30_000, ts=TS, s4=s4, tau0=0.1, nspa=8, warmup=1000)
    per_trial = s4_index(real.z)
    se = per_trial.std(ddof=1) / np.sqrt(per_trial.size)
    assert se < 0.01
    assert abs(per_trial.mean() - s4) <= 4 * se, (per_trial.mean(), se)


def test_csm_refuses_s4_above_one():
    assert S4_MAX == 1.0
    with pytest.raises(ValueError, match=r"S4 1\.5 .*CSM generator realises.*S4 <= 1"):
        generate_csm(seed=1, name="x", trials=[0], n_epochs=100, ts=TS, s4=1.5, tau0=0.2)
    with pytest.raises(ValueError, match=r"S4 1\.2"):
        generate_csm_profile(seed=1, name="x", trials=[0], n_epochs=100, ts=TS, segments=[Segment(0.0, 0.5, 0.4), Segment(0.5, 1.2, 0.2)])


def test_default_configs_validate(config):
    validate_config(config, SCHEMA)
    validate_config(load_config([REPO / "config" / "config.yaml", REPO / "config" / "smoke.yaml"]), SCHEMA)


def test_config_refuses_s4_above_one(config):
    msg = _refused(config, lambda c: c["scenarios"]["s4_0.9_tau0_0.1"]["segments"][0].update(s4=1.5))
    assert "scenarios.s4_0.9_tau0_0.1.segments[0].s4" in msg and "use S4 <= 1" in msg
    msg = _refused(config, lambda c: c["scenarios"]["s4_0.9_tau0_0.1"]["segments"][0].update(s4=float("nan")))  # passes the schema bounds
    assert "scenarios.s4_0.9_tau0_0.1.segments[0]" in msg  # refused (by the finite-number check or by scintrack.validity)
    msg = _refused(config, lambda c: c["ar_training"].update(s4=[0.5, 1.2]))
    assert "ar_training.s4[1]" in msg
    # what the schema cannot reach: an explicit tracker design, a scenario's own adaptation points
    msg = _refused(config, lambda c: c["trackers"]["aekf_pred_0.9"].update(design={"s4": 1.2, "tau0": 0.1}))
    assert "'trackers.aekf_pred_0.9.design'" in msg and "above 1, the largest S4 the CSM generator realises" in msg
    msg = _refused(config, lambda c: c["scenarios"]["s4_0.5_tau0_0.4"].update(tracking={"adaptation_points": [[0.5, 0.4], [1.3, 0.1]]}))
    assert "'scenarios.s4_0.5_tau0_0.4.tracking.adaptation_points[1]'" in msg and "S4 1.3" in msg and "is above 1" in msg


# --- nearest-point look-ups must be on the grid ---------------------------------------------------


def test_off_grid_lookups_are_refused_naming_the_key(config):
    msg = _refused(config, lambda c: c["scenarios"]["ar_s4_0.8_tau0_0.2"]["segments"][0].update(tau0=0.25))
    assert "'scenarios.ar_s4_0.8_tau0_0.2.segments[0]'" in msg
    assert "(S4=0.8, tau0=0.25)" in msg and "nearest point S4=0.8, tau0=0.3" in msg and "add the point to ar_training.s4/tau0" in msg
    msg = _refused(config, lambda c: c["trackers"]["aekf_pred_0.9"].update(design={"s4": 0.85, "tau0": 0.1}))
    assert "'trackers.aekf_pred_0.9.design'" in msg and "(S4=0.85, tau0=0.1)" in msg
    msg = _refused(config, lambda c: c["tracking"].update(adaptation_points=[[0.25, 1.0]]))
    assert "'tracking.adaptation_points[0]'" in msg

    # design: scenario on the first segment of a time-varying profile (floors do not use this scenario)
    def profile(c):
        c["scenarios"]["severe_to_moderate"]["segments"][0].update(s4=0.85)

    msg = _refused(config, profile)
    assert "'scenarios.severe_to_moderate.segments[0]'" in msg and "design: scenario of tracker 'akf_ar'" in msg
    # a CSM-only scenario (no AR look-up) may use any S4 <= 1
    cfg = copy.deepcopy(config)
    cfg["scenarios"]["free"] = {"duration_s": 60.0, "segments": [{"start_s": 0.0, "s4": 0.85, "tau0": 0.25}]}
    validate_config(cfg, SCHEMA)
    # within the tolerance (0.005 in S4) the grid point is used
    cfg = copy.deepcopy(config)
    cfg["trackers"]["aekf_pred_0.9"]["design"] = {"s4": 0.903, "tau0": 0.1}
    validate_config(cfg, SCHEMA)


def _lut() -> xr.Dataset:
    """A two-by-two table with the layout of models.lut (coef, const, sigma2)."""
    s4, tau0, comps, orders = [0.5, 0.9], [0.1, 0.4], ["amplitude", "phase"], [1, 2, 3]
    coef = np.zeros((2, 2, 2, 3, 3))
    coef[:, :, 0, 2] = [1.8, -0.9, 0.05]
    coef[:, :, 1, 0, 0] = 0.99
    coef[:, :, 1, 1, :2] = [1.9, -0.91]
    coef[:, :, 1, 2] = [0.5, 0.2, 0.1]
    const = np.zeros((2, 2, 2, 3))
    const[:, :, 0] = 0.05
    return xr.Dataset(
        {"coef": (("s4", "tau0", "component", "order", "lag"), coef), "const": (("s4", "tau0", "component", "order"), const),
         "sigma2": (("s4", "tau0", "component", "order"), np.full((2, 2, 2, 3), 1e-4))},
        coords={"s4": s4, "tau0": tau0, "component": comps, "order": orders, "lag": orders},
    )


def test_the_point_used_is_recorded(config):
    lut = _lut()
    ctx = TrackerContext(scenario={"duration_s": 1.0, "segments": [{"start_s": 0.0, "s4": 0.503, "tau0": 0.4}]}, tracking=config["tracking"], lut=lut, ts=TS)
    assert AEKFAR.from_spec({"type": "aekf_ar", "design": "scenario"}, ctx).design_point == (0.5, 0.4)
    assert AEKFAR.from_spec({"type": "aekf_ar", "design": {"s4": 0.9, "tau0": 0.1}}, ctx).design_point == (0.9, 0.1)
    assert AEKFAR.from_spec({"type": "aekf_ar", "design": "none"}, ctx).design_point is None
    assert AKFAR.from_spec({"type": "akf_ar", "design": "scenario"}, ctx).design_point == (0.5, 0.4)
    real = simulate("ar_x", {"duration_s": 1.0, "scintillation_model": "ar", "segments": [{"start_s": 0.0, "s4": 0.897, "tau0": 0.1}]},
                    TrackingSettings.from_params(config["tracking"]),
                    seed=1, ts=TS, nspa=8, warmup_s=0.0, trials=range(2), lut=lut)
    assert real.model_point == (0.9, 0.1)
    assert np.all(real.s4_t == 0.9) and np.all(real.tau0_t == 0.1)


# --- the S4 estimator: NaN when not estimable -------------------------------------------------------


def test_s4_corrected_closed_form_and_not_estimable():
    # known moments: I = |A rho e^{j theta} + n|^2 with S = A^2 E[rho^2], E[I] = S + s2, Var[I] = S^2 S4^2 + 2 S s2 + s2^2
    for s, s2, s4 in [(1.0, 0.1, 0.7), (2.0, 0.01, 0.3), (1.0, 0.5, 1.0), (3.0, 0.0, 0.9)]:
        mean, var = s + s2, s * s * s4 * s4 + 2 * s * s2 + s2 * s2
        assert blocks.s4_corrected(mean, var, s2) == pytest.approx(s4, rel=1e-12)
    # 10 dB-Hz at 10 ms: S = 1, s2 = 10; the M2M4 noise over-estimates by 5 % -> mean - s2 <= 0 (was S4 ~ 1e12)
    assert np.isnan(blocks.s4_corrected(11.0, 121.0, 10.5))
    assert np.isnan(blocks.s4_corrected(10.5, 110.0, 10.0))  # S = 0.05 s2
    # the bound S = 0.1 s2 itself is not estimable, just above it is
    assert np.isnan(blocks.s4_corrected(11.0, 121.0, 10.0))
    assert blocks.s4_corrected(11.0 + 1e-9, 121.0, 10.0) == pytest.approx(1.0, rel=1e-6)
    # absurd: S4 >= 2 (S4_ESTIMABLE_MAX) and non-finite moments
    assert np.isnan(blocks.s4_corrected(1.0, 4.0, 0.0)) and blocks.s4_corrected(1.0, 3.99, 0.0) == pytest.approx(np.sqrt(3.99))
    assert np.isnan(blocks.s4_corrected(np.nan, 1.0, 0.1)) and np.isnan(blocks.s4_corrected(1.0, np.inf, 0.1))
    # the ufunc form is the scalar one, NaN included
    mean = np.array([1.1, 11.0, 10.5, 1.0, 2.0])
    var = np.array([0.5, 121.0, 110.0, 4.0, 0.1])
    s2 = np.array([0.1, 10.5, 10.0, 0.0, 0.5])
    out = s4_corrected(mean, var, s2)
    assert np.array_equal(out, [blocks.s4_corrected(a, b, c) for a, b, c in zip(mean, var, s2)], equal_nan=True)
    assert np.isnan(out[1:4]).all() and np.isfinite(out[[0, 4]]).all()
    assert estimable_fraction(out) == pytest.approx(0.4)


def test_s4_of_prompts_at_10_dbhz_is_never_absurd():
    """Prompts at 10 dB-Hz (S/s2 = 0.1 at 10 ms) with an M2M4-like noise estimate 2 % high: the old floor gave
    S4 ~ 1e6..1e12; now every estimate is NaN or a number below 2."""
    rng = np.random.default_rng(4)
    s2 = 10.0
    n = np.sqrt(s2 / 2) * (rng.standard_normal((200, 1000)) + 1j * rng.standard_normal((200, 1000)))
    est = s4_batch(1.0 + n, 1.02 * s2)
    assert np.all(np.isnan(est) | (est < 2.0))
    assert 0.0 < estimable_fraction(est) < 0.5


def test_streaming_s4_holds_the_last_estimable_value():
    est = StreamingS4(1, 50, prior=0.3, min_epochs=20)
    rng = np.random.default_rng(2)
    for _ in range(60):  # high-SNR fading: estimable
        out = est.update(np.array([1.0 + 0.5 * rng.standard_normal()]), np.array([0.01]))
    assert np.isfinite(out[0]) and est.held[0] == out[0]
    last = est.held[0]
    for _ in range(60):  # the noise power now exceeds the mean intensity: not estimable
        out = est.update(np.array([1.0 + 0.5 * rng.standard_normal()]), np.array([100.0]))
    assert np.isnan(out[0]) and est.held[0] == last


# --- the AEKF-AR: a NaN estimate never chooses the AR set ---------------------------------------------


def test_aekf_nan_estimates_hold_the_ar_set():
    """Scintillating prompts (S4 ~ 0.9) with a signal-free reference correlator of power 0 for 20 s (the S4
    estimate is the raw S4, ~0.9: set 2 is chosen), then of power 1e4 (far above the mean intensity: every estimate
    NaN).  The AR set must stay 2 (the last estimable S4 held), the recorded s4_hat shows NaN; a NaN passed
    to nearest_index would give set 0 after adapt_hold epochs.  The numpy reference agrees."""
    n, k, half = 3, 4000, 2000
    z = generate_csm(seed=5, name="hold", trials=range(n), n_epochs=k, ts=TS, s4=0.9, tau0=0.1, warmup=500).z
    y = z * np.exp(1j * 0.1 * np.arange(k))[None, :]
    nref = np.zeros((n, k), dtype=complex)
    nref[:, half:] = 100.0  # |n_ref|^2 = 1e4: from its first epoch the window mean (>= 100) exceeds the mean intensity (~1)
    gamma = [1.8, -0.9, 0.05]
    sets = [ScintillationAR.no_scintillation(), ScintillationAR.from_coefs([1.9, -0.91], gamma, 0.05, 4e-4, 1e-4, s4=0.5),
            ScintillationAR.from_coefs([0.99], gamma, 0.05, 4e-4, 1e-4, s4=0.9)]
    tr = AEKFAR(ts=TS, q_jerk=0.01, p0_diag=(0.25, 1.0, 1e4), ar_sets=sets, adaptive=True, nominal_noise=1e-3, s4_window=500, s4_min_epochs=100,
                adapt_hold=50, noise_estimate="reference", record=("s4_hat", "ar_set"))
    init = TrackInit(phase=np.angle(y[:, 0]), doppler_hz=np.zeros(n), rate_hz_s=np.zeros(n), noise_reference=nref)
    fast = tr.run(y, init)
    s4_hat, ar_set = fast.extras["s4_hat"], fast.extras["ar_set"]
    assert np.all(np.abs(s4_hat[:, 1000:half] - 0.9) < 0.3)
    assert np.all(ar_set[:, half - 1] == 2)
    late = slice(half + tr.noise_window, k)
    assert np.isnan(s4_hat[:, late]).all()
    assert np.all(ar_set[:, half:] == 2)
    ref = tr.reference(y, init)
    assert np.array_equal(ref.extras["ar_set"], ar_set)
    assert np.array_equal(np.isnan(ref.extras["s4_hat"]), np.isnan(s4_hat))
