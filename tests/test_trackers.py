"""Trackers: theory at high C/N0, SSM equivalence, slips, batch invariance, robustness,
compiled kernels against the textbook numpy references, result labels."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import xarray as xr
from conftest import REPO
from scipy.linalg import solve_discrete_are

from scintrack.config import load_config
from scintrack.experiments.merge import merge
from scintrack.experiments.metrics import count_cycle_slips, slip_counts, unwrapped_error, wrap
from scintrack.experiments.runner import run_shard
from scintrack.models.ar import ScintillationAR
from scintrack.signals.correlator import complex_noise, noise_power, prompts
from scintrack.signals.dynamics import third_order_phase
from scintrack.trackers.aekf_ar import AEKFAR
from scintrack.trackers.base import TrackInit, atan2_discriminator, atan_variance, dynamics_F, dynamics_Q
from scintrack.trackers.kf import DiscriminatorKF
from scintrack.trackers.pll import PLL

TS = 0.01


@pytest.mark.parametrize("cn0_dbhz", [28.0, 30.0, 35.0])
def test_eq12_variance_matches_monte_carlo_discriminator(cn0_dbhz):
    s2 = noise_power(cn0_dbhz, TS)
    y = 1.0 + complex_noise(0, "disc", range(1), 400_000, s2)[0]
    mc = np.var(atan2_discriminator(y, np.zeros_like(y.real)))
    assert abs(atan_variance(10 ** (cn0_dbhz / 10), TS) / mc - 1) < 0.08


def _clean_run(tracker, cn0_dbhz=45.0, n=200, k=3000, seed=1):
    thd = third_order_phase(np.zeros(n), k, TS, 50.0, 100.0)
    y = prompts(thd, 1.0, complex_noise(seed, "clean", range(n), k, noise_power(cn0_dbhz, TS)))
    init = TrackInit(phase=np.angle(y[:, 0]), doppler_hz=np.full(n, 50.0), rate_hz_s=np.full(n, 100.0))
    e = unwrapped_error(tracker.run(y, init).theta_d, thd)
    return e[:, k // 2 :]


def _kf_steady_var(q, r):
    F, Q, H = dynamics_F(TS), dynamics_Q(q, TS), np.array([[1.0, 0.0, 0.0]])
    p_prior = solve_discrete_are(F.T, H.T, Q, np.array([[r]]))
    k = p_prior @ H.T / (H @ p_prior @ H.T + r)
    return float(((np.eye(3) - k @ H) @ p_prior)[0, 0])


def test_pll_jitter_matches_loop_theory():
    bn, cn0 = 5.0, 10 ** 4.5
    e = _clean_run(PLL(ts=TS, bandwidth_hz=bn))
    theory = bn / cn0 * (1 + 1 / (2 * cn0 * TS))
    assert np.all(np.abs(e) < 1.0)
    assert abs(np.var(e) / theory - 1) < 0.2, (np.var(e), theory)


@pytest.mark.parametrize("adaptive", [False, True])
def test_kf_and_akf_error_matches_riccati(adaptive):
    cn0 = 10 ** 4.5
    q = 1.0
    kf = DiscriminatorKF(ts=TS, q_jerk=q, nominal_cn0_hz=cn0, p0_diag=(0.1, 1.0, 1.0), adaptive_r=adaptive, cn0_window=200)
    e = _clean_run(kf)
    theory = _kf_steady_var(q, float(atan_variance(cn0, TS)))
    assert abs(np.var(e) / theory - 1) < 0.15, (np.var(e), theory)


def test_aekf_without_scintillation_matches_riccati():
    cn0 = 10 ** 4.5
    q = 1.0
    s2 = noise_power(45.0, TS)
    ekf = AEKFAR(ts=TS, q_jerk=q, p0_diag=(0.1, 1.0, 1.0), ar_sets=[ScintillationAR.no_scintillation()], nominal_noise=s2, rho_p0=1e-4)
    e = _clean_run(ekf)
    theory = _kf_steady_var(q, 1 / (2 * cn0 * TS))
    assert abs(np.var(e) / theory - 1) < 0.15, (np.var(e), theory)


def test_ssm_equivalence_ar13_equals_ar33_with_zero_betas():
    rng = np.random.default_rng(4)
    n, k = 20, 1500
    thd = third_order_phase(rng.uniform(-np.pi, np.pi, n), k, TS, 50.0, 100.0)
    ths = np.cumsum(rng.normal(0, 0.02, (n, k)), axis=1)
    rho = 1 + 0.1 * np.sin(np.arange(k) / 30.0)
    y = prompts(thd + ths, rho, complex_noise(5, "eq", range(n), k, noise_power(30.0, TS)))
    init = TrackInit(phase=np.angle(y[:, 0]), doppler_hz=np.full(n, 50.0), rate_hz_s=np.zeros(n))
    s = ScintillationAR.from_coefs(np.array([0.99]), np.array([1.8, -0.9, 0.05]), kappa=0.05, sigma2_theta=4e-4, sigma2_rho=1e-4, s4=0.8)
    outs = [AEKFAR(ts=TS, q_jerk=0.01, p0_diag=(0.25, 1.0, 1e4), ar_sets=[s], p_state=p, q_state=3, nominal_noise=0.1).run(y, init).theta_d for p in (1, 2, 3)]
    assert np.max(np.abs(outs[0] - outs[1])) < 1e-8
    assert np.max(np.abs(outs[0] - outs[2])) < 1e-8


def test_cycle_slip_counter_counts_injected_slips_exactly():
    rng = np.random.default_rng(0)
    k = 5000
    e = np.clip(rng.normal(0, 0.8, (3, k)), -3.5, 3.5)  # noise within pi + 0.5 of the cell centre
    e[1, 1000:] += 2 * np.pi
    e[1, 3000:] += 2 * np.pi
    e[2, 2000:] -= 3 * 2 * np.pi  # a 3-cycle slip at once
    assert list(count_cycle_slips(e, hysteresis=0.5)) == [0, 2, 3]
    cycles, events = slip_counts(e, 0.5, settle=100)
    assert list(events) == [0, 2, 1]


def test_cycle_slip_counter_counts_a_runaway_loop_per_cycle():
    e = np.linspace(0, 10 * 2 * np.pi, 10_000)[None, :]
    assert count_cycle_slips(e, 0.5)[0] == 10
    assert slip_counts(e, 0.5, settle=2000)[1][0] == 1  # one loss of lock


def test_wrapped_error_range():
    w = wrap(np.linspace(-20, 20, 1001))
    assert w.min() >= -np.pi and w.max() <= np.pi


@pytest.fixture(scope="module")
def config():
    return load_config([REPO / "config" / "config.yaml"])


def _lut():
    s4 = [0.4, 0.5, 0.8, 0.9, 1.0]
    order = np.arange(1, 4)
    coef = np.zeros((len(s4), 1, 2, 3, 3))
    for i in range(len(s4)):
        for o in order:
            coef[i, 0, 0, o - 1, :3] = [1.8, -0.9, 0.05]  # amplitude
            coef[i, 0, 1, o - 1, :o] = [0.99, 0.0, 0.0][:o]  # phase
    return xr.Dataset(
        {
            "coef": (("s4", "tau0", "component", "order", "lag"), coef),
            "const": (("s4", "tau0", "component", "order"), np.full((len(s4), 1, 2, 3), 0.05)),
            "sigma2": (("s4", "tau0", "component", "order"), np.full((len(s4), 1, 2, 3), 1e-3)),
        },
        coords={"s4": s4, "tau0": [0.2], "component": ["amplitude", "phase"], "order": order, "lag": order},
    )


def _shard(config, trials, scenario, cn0=None, duration=3.0):
    sc = copy.deepcopy(config["scenarios"][scenario])
    sc["duration_s"] = duration
    if cn0 is not None:
        sc["cn0_dbhz"] = cn0
    tracking = dict(config["tracking"], steady_state_start_s=1.0, adaptation_points=[[0.5, 0.2], [0.9, 0.2]])
    return run_shard(
        scenario_name=scenario, scenario=sc, tracker_names=["pll", "kf", "akf", "akf_ar", "aekf_ar"], tracker_specs=config["trackers"],
        tracking=tracking, lut=_lut(), seed=7, ts=TS, nspa=8, warmup_s=1.0, trials=trials,
    )


def test_trial_result_is_independent_of_the_batch(config):
    batch = _shard(config, range(500), "s4_0.8_tau0_0.2", duration=1.5)
    alone = _shard(config, [123], "s4_0.8_tau0_0.2", duration=1.5)
    np.testing.assert_allclose(batch["ms_steady"].sel(trial=123).values, alone["ms_steady"].sel(trial=123).values, rtol=1e-12, atol=1e-14)
    np.testing.assert_array_equal(batch["slips"].sel(trial=123).values, alone["slips"].sel(trial=123).values)


def test_no_tracker_returns_nan_at_10_dbhz_and_s4_1(config):
    """At the edge of the CSM's range (S4 = 1, the largest it realises; above it the config is refused)."""
    config = copy.deepcopy(config)
    config["scenarios"]["harsh"] = {"duration_s": 3.0, "segments": [{"start_s": 0.0, "s4": 1.0, "tau0": 0.1}]}
    res = _shard(config, range(20), "harsh", cn0=10.0)
    assert np.all(np.isfinite(res["ms_steady"].values))
    assert np.all(np.isfinite(res["sq_sum"].values))


def test_compiled_kernels_match_textbook_references():
    """Kernel (closed-form blocks) against the textbook numpy filter (explicit F, Q, H,
    S = H P H^T + R, K = P H^T S^-1 by numpy.linalg, P = (I - K H) P) over 3000 epochs.

    Tolerance: theta_d is the absolute carrier phase (up to ~3e5 rad after 30 s
    at 50 Hz + 100 Hz/s), and the two derivations differ only by rounding
    (observed: <= 4e-14 relative, 1e-8 rad absolute), so rtol = 1e-10 leaves
    four orders of margin while any algebra error (a wrong Jacobian entry, a
    missing kappa, a transposed gain) gives O(1e-3..1) differences.  The S4
    estimate differs by up to ~6e-9 (the window re-sum is numpy pairwise in one,
    sequential in the other; near S4 = 0 the square root amplifies ulps), hence
    atol = 1e-7 there; the AR-set index must be identical.
    """
    from scintrack.experiments.metrics import count_cycle_slips_numpy

    rng = np.random.default_rng(9)
    n, k = 6, 3000
    thd = third_order_phase(rng.uniform(-np.pi, np.pi, n), k, TS, 50.0, 100.0)
    ths = np.cumsum(rng.normal(0, 0.03, (n, k)), axis=1)
    rho = np.abs(1 + 0.4 * np.sin(np.arange(k) / 25.0))
    y = prompts(thd + ths, rho, complex_noise(5, "ref", range(n), k, noise_power(27.0, TS)))
    init = TrackInit(phase=np.angle(y[:, 0]), doppler_hz=np.full(n, 50.0), rate_hz_s=np.zeros(n))
    gamma = np.array([1.8, -0.9, 0.05])
    sets = [ScintillationAR.no_scintillation(), ScintillationAR.from_coefs([1.9, -0.91], gamma, 0.05, 4e-4, 1e-4, s4=0.5),
            ScintillationAR.from_coefs([0.99], gamma, 0.05, 4e-4, 1e-4, s4=0.9)]
    trackers = [
        PLL(ts=TS, bandwidth_hz=10.0),
        PLL(ts=TS, bandwidth_hz=10.0, discriminator="atan"),
        DiscriminatorKF(ts=TS, q_jerk=0.01, nominal_cn0_hz=1000.0, p0_diag=(0.25, 1.0, 1e4)),
        DiscriminatorKF(ts=TS, q_jerk=0.01, nominal_cn0_hz=1000.0, p0_diag=(0.25, 1.0, 1e4), adaptive_r=True),
        DiscriminatorKF(ts=TS, q_jerk=0.01, nominal_cn0_hz=1000.0, p0_diag=(0.25, 1.0, 1e4), adaptive_r=True, ar_coefs=np.array([0.99]), ar_sigma2=4e-4),
        AEKFAR(ts=TS, q_jerk=0.01, p0_diag=(0.25, 1.0, 1e4), ar_sets=sets, adaptive=True, nominal_noise=0.2, s4_window=300, s4_min_epochs=100, adapt_hold=50,
               record=("s4_hat", "ar_set", "theta_s", "rho_s")),
        AEKFAR(ts=TS, q_jerk=0.01, p0_diag=(0.25, 1.0, 1e4), ar_sets=sets[1:2], nominal_noise=0.2, fold_mirror=True, record=("rho_s", "theta_s")),
        AEKFAR(ts=TS, q_jerk=0.01, p0_diag=(0.25, 1.0, 1e4), ar_sets=sets[2:], p_state=1, q_state=3, nominal_noise=0.2, record=("rho_s",)),
        # the structured predict / lane kernel on other state orders (a set of each order), static (q = 0, P0_d = 0), nothing recorded
        AEKFAR(ts=TS, q_jerk=0.01, p0_diag=(0.25, 1.0, 1e4), ar_sets=[ScintillationAR.from_coefs([1.9, -0.91], [0.98], 0.02, 4e-4, 1e-4)],
               p_state=2, q_state=1, nominal_noise=0.2, record=("rho_s", "theta_s")),
        AEKFAR(ts=TS, q_jerk=0.01, p0_diag=(0.25, 1.0, 1e4), ar_sets=[ScintillationAR.no_scintillation(), ScintillationAR.from_coefs([0.99], [1.7, -0.72], 0.02, 4e-4, 1e-4, s4=0.5)],
               p_state=3, q_state=2, adaptive=True, nominal_noise=0.2, s4_window=300, s4_min_epochs=100, adapt_hold=50, fold_mirror=True, amplitude_floor=0.02,
               record=("ar_set", "s4_hat")),
        AEKFAR(ts=TS, q_jerk=0.0, p0_diag=(0.0, 0.0, 0.0), ar_sets=sets[1:2], nominal_noise=0.2),
    ]
    tol = {"frequency_hz": dict(rtol=1e-10, atol=1e-9), "discriminator": dict(rtol=0, atol=1e-7), "total_phase": dict(rtol=1e-10, atol=1e-9), "s4_hat": dict(rtol=1e-6, atol=1e-7), "ar_set": dict(rtol=0, atol=0), "R": dict(rtol=1e-10, atol=0), "theta_s": dict(rtol=0, atol=1e-8), "rho_s": dict(rtol=0, atol=1e-8), "cov_fail_epoch": dict(rtol=0, atol=0)}
    for tr in trackers:
        fast, ref = tr.run(y, init), tr.reference(y, init)
        np.testing.assert_allclose(fast.theta_d, ref.theta_d, rtol=1e-10, atol=1e-9, err_msg=type(tr).__name__)
        assert set(fast.extras) == set(ref.extras)
        for key in fast.extras:
            np.testing.assert_allclose(fast.extras[key], ref.extras[key], err_msg=f"{type(tr).__name__} {key}", **tol[key])
    for j in (5, 9):
        switched = trackers[j].run(y, init).extras["ar_set"]
        assert len(np.unique(switched)) > 1  # the adaptive filter did switch sets
    e = unwrapped_error(trackers[0].run(y, init).theta_d, thd)
    np.testing.assert_array_equal(count_cycle_slips(e), count_cycle_slips_numpy(e))


def test_reference_catches_a_wrong_model():
    """The reference is an independent derivation: a kernel fed a different
    model (here a wrong kappa) is caught by the same tolerance."""
    rng = np.random.default_rng(2)
    n, k = 3, 800
    thd = third_order_phase(rng.uniform(-np.pi, np.pi, n), k, TS, 50.0, 100.0)
    y = prompts(thd, 1.0, complex_noise(1, "wrong", range(n), k, noise_power(30.0, TS)))
    init = TrackInit(phase=np.angle(y[:, 0]), doppler_hz=np.full(n, 50.0), rate_hz_s=np.zeros(n))
    kw = dict(ts=TS, q_jerk=0.01, p0_diag=(0.25, 1.0, 1e4), nominal_noise=0.1)
    good = AEKFAR(ar_sets=[ScintillationAR.from_coefs([0.99], [0.9], 0.1, 1e-4, 1e-3)], **kw)
    bad = AEKFAR(ar_sets=[ScintillationAR.from_coefs([0.99], [0.9], 0.12, 1e-4, 1e-3)], **kw)
    with pytest.raises(AssertionError):
        np.testing.assert_allclose(bad.run(y, init).theta_d, good.reference(y, init).theta_d, rtol=1e-10, atol=1e-9)


def test_shards_merge_exactly(config):
    whole = merge([_shard(config, range(4), "s4_0.8_tau0_0.2", duration=1.5)])
    parts = merge([_shard(config, [2, 3], "s4_0.8_tau0_0.2", duration=1.5), _shard(config, [0, 1], "s4_0.8_tau0_0.2", duration=1.5)])
    np.testing.assert_allclose(parts["sq_sum"].values, whole["sq_sum"].values, rtol=1e-12)
    np.testing.assert_allclose(parts["steady_rmse"].values, whole["steady_rmse"].values, rtol=1e-12)
    np.testing.assert_array_equal(parts["slips"].values, whole["slips"].values)
    assert int(parts["example_trial"]) == 0


def test_mirror_fold_keeps_rho_positive_and_changes_nothing_in_lock():
    """fold_mirror (isolating option): never a negative amplitude estimate; with a
    strong signal that never fades, the fold never triggers and results are identical."""
    rng = np.random.default_rng(4)
    n, k = 4, 3000
    thd = third_order_phase(rng.uniform(-np.pi, np.pi, n), k, TS, 50.0, 100.0)
    s = ScintillationAR.from_coefs(np.array([0.995]), np.array([1.9, -0.95, 0.0]), kappa=0.05, sigma2_theta=1e-3, sigma2_rho=2e-3, s4=0.8)
    init = lambda y: TrackInit(phase=np.angle(y[:, 0]), doppler_hz=np.full(n, 50.0), rate_hz_s=np.zeros(n))  # noqa: E731
    kw = dict(ts=TS, q_jerk=0.01, p0_diag=(0.25, 1.0, 1e4), ar_sets=[s], nominal_noise=0.1, record=("rho_s",))
    fading = np.abs(np.sin(np.arange(k) / 60.0)) + 1e-3  # through zero every ~1.9 s
    y = prompts(thd, fading, complex_noise(6, "fold", range(n), k, noise_power(30.0, TS)))
    plain = AEKFAR(**kw).run(y, init(y))
    folded = AEKFAR(**kw, fold_mirror=True).run(y, init(y))
    assert (plain.extras["rho_s"] < 0).mean() > 0.01  # the unfolded filter does visit the mirror
    assert (folded.extras["rho_s"] >= 0).all()
    steady = np.ones(k)
    y2 = prompts(thd, steady, complex_noise(7, "fold2", range(n), k, noise_power(45.0, TS)))
    np.testing.assert_array_equal(AEKFAR(**kw).run(y2, init(y2)).theta_d, AEKFAR(**kw, fold_mirror=True).run(y2, init(y2)).theta_d)


def test_shard_carries_tracker_labels_as_an_attribute_only(config):
    import json

    from scintrack.io import content_hash

    ds = _shard(config, range(2), "s4_0.8_tau0_0.2", duration=1.5)
    labels = json.loads(ds.attrs["tracker_labels"])
    assert labels == {"pll": "PLL", "kf": "KF", "akf": "AKF", "akf_ar": "AKF-AR", "aekf_ar": "AEKF-AR"}
    assert "tracker_labels" not in ds.variables
    stripped = ds.copy()
    del stripped.attrs["tracker_labels"]
    assert content_hash(ds) == content_hash(stripped)


def test_costas_discriminator_ignores_the_data_bit_and_the_pll_tracks_through_bit_flips():
    from scintrack.trackers import blocks

    rng = np.random.default_rng(5)
    phase = rng.uniform(-1.2, 1.2, 200)
    for err in (-1.0, -0.3, 0.0, 0.4, 1.2):
        y = np.exp(1j * (phase + err))
        assert np.allclose(blocks.atan_discriminator_ufunc(y.real, y.imag, phase), err)
        assert np.allclose(blocks.atan_discriminator_ufunc(-y.real, -y.imag, phase), err)  # d = -1: same error
    # 40 dB-Hz, 1 ms, random bits every 20 ms: the Costas loop stays locked (mod pi), the ATAN2 loop does not
    ts, n = 1e-3, 4000
    bits = np.repeat(rng.choice([-1.0, 1.0], n // 20), 20)
    theta = 2 * np.pi * 3.0 * ts * np.arange(n)
    noise = (rng.standard_normal((4, n)) + 1j * rng.standard_normal((4, n))) * np.sqrt(1 / (2 * 1e4 * ts))
    y = bits * np.exp(1j * theta) + noise
    init = TrackInit(phase=np.zeros(4), doppler_hz=np.full(4, 3.0), rate_hz_s=np.zeros(4))
    costas = PLL(ts=ts, bandwidth_hz=10.0, discriminator="atan").run(y, init)
    err = np.angle(np.exp(2j * (costas.theta_d - theta))) / 2  # modulo pi
    assert np.sqrt(np.mean(err[:, 500:] ** 2)) < 0.1
    assert np.allclose(costas.extras["frequency_hz"][:, 500:].mean(), 3.0, atol=0.2)


def _aekf_batch(n, k, seed=3):
    rng = np.random.default_rng(seed)
    thd = third_order_phase(rng.uniform(-np.pi, np.pi, n), k, TS, 50.0, 100.0)
    rho = np.abs(1 + 0.6 * np.sin(np.arange(k) / 20.0 + rng.uniform(0, 6, (n, 1))))
    y = prompts(thd + np.cumsum(rng.normal(0, 0.03, (n, k)), axis=1), rho, complex_noise(seed, "lanes", range(n), k, noise_power(27.0, TS)))
    return y, TrackInit(phase=np.angle(y[:, 0]), doppler_hz=np.full(n, 50.0), rate_hz_s=np.zeros(n))


def test_aekf_lanes_give_each_trial_the_bits_it_has_alone():
    """The kernel runs blocks.LANES trials side by side (the last block padded): every trial's output is,
    bit for bit, the one of a run on that trial alone, wherever it sits in the batch."""
    from scintrack.trackers import blocks

    n = blocks.LANES + 5
    y, init = _aekf_batch(n, 700)
    sets = [ScintillationAR.no_scintillation(), ScintillationAR.from_coefs([0.99], [1.8, -0.9, 0.05], 0.05, 4e-4, 1e-4, s4=0.6)]
    tr = AEKFAR(ts=TS, q_jerk=0.01, p0_diag=(0.25, 1.0, 1e4), ar_sets=sets, adaptive=True, nominal_noise=0.2, s4_window=200, s4_min_epochs=50,
                adapt_hold=20, fold_mirror=True, record=("theta_s", "rho_s", "s4_hat", "ar_set"))
    batch = tr.run(y, init)
    for t in (0, blocks.LANES - 1, blocks.LANES, n - 1):
        alone = tr.run(y[t : t + 1], TrackInit(init.phase[t : t + 1], init.doppler_hz[t : t + 1], init.rate_hz_s[t : t + 1]))
        assert np.array_equal(batch.theta_d[t], alone.theta_d[0])
        for key in tr.record:
            assert np.array_equal(batch.extras[key][t], alone.extras[key][0]), key


def test_lane_blocks_are_the_scalar_blocks_bit_for_bit():
    """The Lanes forms (blocks.ar_predict, window_push_lanes, nearest_index_lanes, and m2m4_split /
    window_mean_var / s4_corrected compiled for Lanes) give on every lane the bits of the scalar block."""
    from numba import njit

    from scintrack.simd import LANES as L
    from scintrack.simd.lanes import lane_load, lane_store
    from scintrack.trackers import blocks

    rng = np.random.default_rng(11)
    # formulas: edge values (zeros, negatives, tiny and large) on every lane
    m = 64
    a = rng.normal(size=(m, L)) * rng.choice([1e-300, 1e-3, 1.0, 1e3], (m, L))
    b, c = rng.normal(size=(m, L)), rng.normal(size=(m, L))
    a[:4], b[4:8], c[8:12] = 0.0, -0.0, 0.0

    @njit
    def lane_forms(a, b, c, out, pts):
        for i in range(a.shape[0]):
            x, yv, z = lane_load(a, i * L), lane_load(b, i * L), lane_load(c, i * L)
            mean, var = blocks.window_mean_var(x, yv, 37)
            sig, noi = blocks.m2m4_split(x, yv, 1e-3)
            for j, v in enumerate((mean, var, blocks.s4_corrected(x, yv, z), sig, noi, blocks.nearest_index_lanes(z, pts))):
                lane_store(out, (j * a.shape[0] + i) * L, v)

    @njit
    def scalar_forms(a, b, c, out, pts):
        for i in range(a.shape[0]):
            for ln in range(L):
                x, yv, z = a[i, ln], b[i, ln], c[i, ln]
                out[0, i, ln], out[1, i, ln] = blocks.window_mean_var(x, yv, 37)
                out[2, i, ln] = blocks.s4_corrected(x, yv, z)
                out[3, i, ln], out[4, i, ln] = blocks.m2m4_split(x, yv, 1e-3)
                out[5, i, ln] = blocks.nearest_index(z, pts)

    pts = np.array([0.0, 0.5, -0.5, 0.5, 1.0])  # a tie: the first index wins
    o1, o2 = np.empty((6, m, L)), np.empty((6, m, L))
    lane_forms(a, b, c, o1, pts)
    scalar_forms(a, b, c, o2, pts)
    assert np.array_equal(o1.view(np.uint64), o2.view(np.uint64))

    # ring buffers: window_push_lanes against window_push per lane, over two laps (the exact re-sum)
    w = 7
    b1, b2, s1, s2 = blocks.lanes_empty((w, L)), blocks.lanes_empty((w, L)), np.zeros(L), np.zeros(L)
    b1[:], b2[:] = 0.0, 0.0
    ref = [(np.zeros(w), np.zeros(w), 0.0, 0.0) for _ in range(L)]
    pos = count = 0
    for _ in range(2 * w + 3):
        v = rng.exponential(size=L)
        v1, v2 = np.ascontiguousarray(v), np.ascontiguousarray(v * v)
        new_pos, new_count = blocks.window_push_lanes(b1, b2, pos, s1, s2, count, v1, v2)
        for ln in range(L):
            rb1, rb2, r1, r2 = ref[ln]
            p_, r1, r2, c_ = blocks.window_push(rb1, rb2, pos, r1, r2, count, v1[ln], v2[ln])
            ref[ln] = (rb1, rb2, r1, r2)
            assert (p_, c_) == (new_pos, new_count)
        pos, count = new_pos, new_count
        assert np.array_equal(s1, [r[2] for r in ref]) and np.array_equal(s2, [r[3] for r in ref])

    # structured predict against the general one (blocks.predict over the non-zeros of F), every state order
    for p, q in ((1, 1), (2, 3), (3, 3), (3, 1)):
        n = 3 + p + q
        sets = [ScintillationAR.from_coefs(rng.normal(0, 0.5, p), rng.normal(0, 0.5, q), 0.03, 1e-4, 2e-4), ScintillationAR.no_scintillation()]
        tr = AEKFAR(ts=TS, q_jerk=0.3, p0_diag=(1.0, 1.0, 1.0), ar_sets=sets, p_state=p, q_state=q)
        F, Q, kap = tr.tables()
        co_tab = blocks.ar_coefficients(F, Q, kap, p, q)
        setof = rng.integers(0, len(sets), L)
        co = blocks.lanes_empty((co_tab.shape[1], L))
        co[:] = co_tab[setof].T
        A = rng.normal(size=(L, n, n))
        P0 = np.einsum("lij,lkj->lik", A, A)
        x, P = blocks.lanes_empty((n, L)), blocks.lanes_empty((n, n, L))
        x[:], P[:] = rng.normal(size=(L, n)).T, P0.transpose(1, 2, 0)
        xn, Pn, G = blocks.lanes_empty((n, L)), blocks.lanes_empty((n, n, L)), blocks.lanes_empty((4, n, L))
        blocks.ar_predict(x, P, xn, Pn, G, co, p, q)
        rows, cols, vals, nnz = blocks.nonzeros(F)
        for ln in range(L):
            j = setof[ln]
            xs, Ps = x[:, ln].copy(), P0[ln].copy()
            blocks.predict(xs, Ps, np.empty(n), np.empty((n, n)), Q[j], kap[j], rows[j], cols[j], vals[j], nnz[j], True)
            assert np.array_equal(xn[:, ln].view(np.uint64), xs.view(np.uint64))  # x bit for bit, signs of zeros included
            assert np.array_equal(Pn[:, :, ln], Ps)  # P equal (an exact zero may differ in sign)
    with pytest.raises(ValueError, match="form"):
        bad = F.copy()
        bad[0, 3, 0] = 0.1
        blocks.ar_coefficients(bad, Q, kap, p, q)


def test_merged_sakf_monitors_average_and_the_T_median_is_the_first_shards_and_says_so(config):
    """phi3, p and the weight merge as trial-weighted means; a median does not merge, so T is the first shard's
    median and carries the trials it covers (``median_trials``), which the SAKF monitor figure states."""
    def shard(trials):
        sc = copy.deepcopy(config["scenarios"]["s4_0.5_tau0_0.4"])
        sc["duration_s"] = 2.0
        tracking = dict(config["tracking"], steady_state_start_s=1.0)
        return run_shard(scenario_name="s4_0.5_tau0_0.4", scenario=sc, tracker_names=["susi_sakf"], tracker_specs=config["trackers"],
                         tracking=tracking, lut=_lut(), seed=7, ts=TS, nspa=8, warmup_s=1.0, trials=trials)

    a, b = shard([0, 1, 2]), shard([3, 4])
    merged = merge([a, b])
    assert int(merged["n_trials"]) == 5 and merged["T_mean"].attrs["median_trials"] == 3
    np.testing.assert_array_equal(merged["T_mean"].values, a["T_mean"].values)
    np.testing.assert_allclose(merged["weight_mean"].values, (3 * a["weight_mean"].values + 2 * b["weight_mean"].values) / 5, rtol=1e-12)
    assert "median_trials" not in a["T_mean"].attrs  # a single job's median covers every trial
