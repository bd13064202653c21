"""Susi et al. 2014's AKF and SAKF PLLs (scintrack.trackers.susi_kf): theory checks."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm

from scintrack.models import clock as clock_models
from scintrack.signals.correlator import complex_noise, noise_power
from scintrack.trackers import blocks, registry
from scintrack.trackers.base import TrackerContext, TrackInit, dynamics_F
from scintrack.trackers.susi_kf import GainWeighting, loop_bandwidth_closed_form, loop_bandwidth_hz, quadratic_detrend, steady_state_gain

TS = 0.001
TRACKING = {"amplitude": 1.0, "cn0_dbhz": 45.0, "p0_diag": [0.25, 1.0, 100.0], "q_jerk_hz2_s3": 0.01}


def _context(clock="ocxo", cn0=45.0):
    return TrackerContext(scenario={"clock": clock, "cn0_dbhz": cn0}, tracking=TRACKING, ts=TS)


def _signal(n, k, cn0=45.0, seed=1, scint=0.0):
    t = np.arange(k) * TS
    rng = np.random.default_rng(seed)
    theta = rng.uniform(-np.pi, np.pi, (n, 1)) + 2 * np.pi * (300.0 * t + 0.25 * t**2)[None, :]
    if scint:
        theta = theta + scint * np.sin(2 * np.pi * 0.7 * t + rng.uniform(0, 6, (n, 1))) + np.cumsum(rng.normal(0, 0.01, (n, k)), axis=1)
    y = np.exp(1j * theta) + complex_noise(seed, "susi", range(n), k, noise_power(cn0, TS))
    init = TrackInit(phase=np.angle(y[:, 0]), doppler_hz=np.full(n, 300.0), rate_hz_s=np.zeros(n))
    return y, init, theta


def test_process_noise_is_the_exact_discretisation_of_eqs_3_to_6():
    """Q (clock h0, h_-2 of eqs. 5-6 plus the rate PSD) equals Van Loan's matrix exponential of the continuous model."""
    trk = registry.build("x", {"type": "susi_akf", "clock": "rubidium"}, _context())
    s_phi, s_f = trk.clock_psd()
    s_a = trk.q_jerk
    c = 2 * math.pi
    A = np.array([[0.0, c, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    W = np.diag([s_phi, s_f, s_a])
    M = np.zeros((6, 6))
    M[:3, :3], M[:3, 3:], M[3:, 3:] = -A, W, A.T
    E = expm(M * TS)
    Q_vl = E[3:, 3:].T @ E[:3, 3:]
    np.testing.assert_allclose(trk.q_base(), Q_vl, rtol=1e-9, atol=1e-30)
    np.testing.assert_allclose(expm(A * TS), dynamics_F(TS), rtol=1e-12, atol=1e-15)
    # the clock part is the clock module's two-state Q, in (rad, Hz)
    q_clk = np.zeros((3, 3))
    blocks.phase_frequency_q(s_phi, s_f, TS, q_clk)
    D = np.diag([c, 1.0])
    np.testing.assert_allclose(q_clk[:2, :2], D @ clock_models.process_noise(clock_models.preset("rubidium"), TS, units="cycles") @ D, rtol=1e-12)


def test_akf_converges_to_the_riccati_gain():
    """With R fixed (eq. 10 at the nominal C/N0) the filter becomes the fixed-gain loop of solve_discrete_are:
    its response to a small phase step after convergence (noise-free input, so the discriminator is linear)
    equals the step response of x+ = (I - K H) F x + K z with the DARE gain K."""
    trk = registry.build("x", {"type": "susi_akf", "discriminator": "atan2", "r": "nominal", "clock": "tcxo_low"}, _context("tcxo_low"))
    k, k0, delta = 30_000, 25_000, 1e-3
    t = np.arange(k) * TS
    theta = 0.2 + 2 * np.pi * (300.0 * t + 0.25 * t**2)
    stepped = theta + np.where(np.arange(k) >= k0, delta, 0.0)
    y = np.exp(1j * np.stack([theta, stepped]))
    init = TrackInit(phase=np.full(2, 0.2), doppler_hz=np.full(2, 300.0), rate_hz_s=np.zeros(2))
    est = trk.run(y, init).theta_d
    measured = (est[1] - est[0])[k0:] / delta
    K = steady_state_gain(trk)
    A = (np.eye(3) - K[:, None] @ np.array([[1.0, 0.0, 0.0]])) @ dynamics_F(TS)
    x, expected = np.zeros(3), np.empty(k - k0)
    for i in range(k - k0):
        x = A @ x + K
        expected[i] = x[0]
    np.testing.assert_allclose(measured, expected, atol=2e-4)
    assert measured.max() > 1.0  # a third-order loop overshoots a phase step


def test_loop_bandwidth_closed_form_and_monte_carlo():
    """Discrete noise bandwidth of the steady-state gains vs the third-order closed form, and vs the
    measured phase-estimate variance on noise alone: var = 2 B Ts var(discriminator)."""
    for clock, cn0 in (("ocxo", 40.0), ("rubidium", 40.0), ("tcxo_high", 45.0)):
        trk = registry.build("x", {"type": "susi_akf", "clock": clock, "r": "nominal", "discriminator": "atan2"}, _context(clock, cn0=cn0))
        K = steady_state_gain(trk)
        b_d, b_c = loop_bandwidth_hz(K, TS), loop_bandwidth_closed_form(K, TS)
        # the continuous form holds for Bn Ts << 1 (here <= 0.03); at Bn Ts = 0.1 (tcxo_low, ~100 Hz) it is 20% off
        assert b_d * TS < 0.03 and abs(b_d / b_c - 1) < 0.03, (clock, b_d, b_c)
    trk = registry.build("x", {"type": "susi_akf", "clock": "tcxo_low", "r": "nominal", "discriminator": "atan2"}, _context("tcxo_low", cn0=40.0))
    K = steady_state_gain(trk)
    n, k = 50, 6000
    s2 = noise_power(40.0, TS)
    y = np.ones((n, k)) + complex_noise(3, "bw", range(n), k, s2)  # phase 0, no dynamics
    init = TrackInit(phase=np.zeros(n), doppler_hz=np.zeros(n), rate_hz_s=np.zeros(n))
    trk.p0_diag = (1e-6, 1e-6, 1e-6)
    est = trk.run(y, init).theta_d[:, 3000:]
    disc_var = np.var(np.angle(y))
    expected = 2 * loop_bandwidth_hz(K, TS) * TS * disc_var
    assert abs(est.var() / expected - 1) < 0.15, (est.var(), expected)


def test_sakf_without_scintillation_terms_and_alpha_1_is_the_akf():
    """Scintillation PSDs off and K(Phi3) flat at alpha = 1: exactly the AKF's estimates (bit for bit), although
    the SAKF still runs its scintillation block every 0.1 s."""
    n, k = 3, 9000
    y, init, _ = _signal(n, k, scint=0.8)
    akf = registry.build("a", {"type": "susi_akf", "discriminator": "atan2"}, _context())
    sakf = registry.build("s", {"type": "susi_sakf", "discriminator": "atan2", "scintillation_q": False, "gain_weighting": {"alpha": 1.0, "exponent": 0.0}}, _context())
    a, s = akf.run(y, init), sakf.run(y, init)
    np.testing.assert_array_equal(a.theta_d, s.theta_d)
    assert np.isfinite(s.extras["p"][:, -1]).all() and np.isfinite(s.extras["phi3"][:, -1]).all()
    full = registry.build("s", {"type": "susi_sakf", "discriminator": "atan2"}, _context())
    assert not np.array_equal(full.run(y, init).theta_d, a.theta_d)


@pytest.mark.parametrize("spec", [
    {"type": "susi_akf"},
    {"type": "susi_akf", "discriminator": "atan2", "r": "nominal", "clock": "rubidium"},
    {"type": "susi_sakf", "discriminator": "atan2"},
    {"type": "susi_sakf", "gain_weighting": {"alpha": 0.5, "exponent": 2.0}, "update_s": 0.05},
])
def test_kernel_matches_textbook_reference(spec):
    """Compiled kernel (closed-form blocks, Joseph P in scalar form) vs the numpy filter with explicit matrices.
    theta_d is an absolute phase of ~1e4 rad here; rounding differences stay below 1e-8 rad, any algebra
    error gives >= 1e-4."""
    n, k = 3, 6000
    y, init, _ = _signal(n, k, scint=0.6, seed=4)
    trk = registry.build("x", spec, _context())
    a, b = trk.run(y, init), trk.reference(y, init)
    np.testing.assert_allclose(a.theta_d, b.theta_d, rtol=0, atol=1e-7)
    for key in a.extras:
        np.testing.assert_allclose(a.extras[key], b.extras[key], rtol=1e-6, atol=1e-9, equal_nan=True)


def test_scintillation_block_reads_a_known_power_law_and_the_weight_is_monotone():
    """The block on windows of a synthetic f^-p phase (plus dynamics) gives p near the truth (the 0.5-5 Hz
    band's documented upward bias included), T at 1 Hz, and Phi3 = the window's std after the quadratic."""
    from scipy import signal

    trk = registry.build("s", {"type": "susi_sakf"}, _context())
    rng = np.random.default_rng(11)
    n_win, n_tr = trk.n_window, 400
    f = np.fft.rfftfreq(4 * n_win, TS)
    p0, T0 = 2.5, 1e-2
    shape = np.sqrt(T0 * np.maximum(f, 0.05) ** (-p0) / (2 * TS))
    white = rng.normal(size=(n_tr, 4 * n_win))
    phi = np.fft.irfft(np.fft.rfft(white) * shape, 4 * n_win)[:, :n_win]
    t = np.arange(n_win) * TS
    out = trk.scintillation_update(phi + 2 * np.pi * (500 * t + 0.4 * t**2))
    assert abs(np.mean(out["p"]) - p0) < 0.4, np.mean(out["p"])
    assert 0.7 < np.exp(np.mean(np.log(out["T"]))) / T0 < 2.0
    np.testing.assert_allclose(out["phi3"], quadratic_detrend(phi)[0].std(axis=1), rtol=1e-6)
    w = GainWeighting(alpha=0.8, phi_ref_rad=0.5, exponent=1.0)(np.array([0.0, 0.1, 1.0, 3.0]))
    assert w[0] == 0.8 and np.all(np.diff(w) < 0)
    s_phi, s_f = trk.scint_psd(np.array([1e-2]), np.array([2.5]))
    np.testing.assert_allclose(s_phi, 1e-2 * 0.19**-2.5)
    np.testing.assert_allclose(s_f, 0.19**2 * s_phi)  # S_f = nu^2 S_phi, rad and Hz (tests/test_susi_readings.py)
    del signal


@pytest.mark.parametrize("n", [3000, 301, 7])
def test_quadratic_detrend_is_the_least_squares_residual_row_by_row(n):
    """Closed forms: the residual of a quadratic is 0, the residual is orthogonal to {1, m, m^2} and equals
    numpy's least-squares residual, its std is numpy's std of it; and a row's residual and std have the same
    bits alone, in a batch of 40, in batches of 32 + 8 and as a strided view (a BLAS product did not, on an
    AVX-512 CPU)."""
    rng = np.random.default_rng(n)
    x = np.cumsum(rng.standard_normal((40, n)), axis=1)
    m = np.linspace(-1.0, 1.0, n)
    quad = 3.0 + 40.0 * m - 7.0 * m * m
    r0, s0 = quadratic_detrend(quad[None, :])
    assert np.abs(r0).max() < 1e-12 * 40.0 and s0[0] < 1e-12 * 40.0
    r, s = quadratic_detrend(x)
    A = np.stack([np.ones(n), m, m * m], axis=1)
    lsq = x.T - A @ np.linalg.lstsq(A, x.T, rcond=None)[0]
    np.testing.assert_allclose(r, lsq.T, rtol=0, atol=1e-11 * np.abs(x).max())
    assert np.abs(r @ A).max() < 1e-10 * np.abs(x).max() * n
    np.testing.assert_allclose(s, r.std(axis=1), rtol=1e-13)
    np.testing.assert_allclose(s, lsq.std(axis=0), rtol=1e-9)
    strided = np.zeros((40, n + 5))
    strided[:, 2 : n + 2] = x
    ways = [
        [quadratic_detrend(x[i : i + 1]) for i in range(40)],
        [quadratic_detrend(x[:32]), quadratic_detrend(x[32:])],
        [quadratic_detrend(strided[:, 2 : n + 2])],
    ]
    for parts in ways:
        r_parts, s_parts = np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
        assert r_parts.view(np.uint64).tolist() == r.view(np.uint64).tolist()
        assert s_parts.view(np.uint64).tolist() == s.view(np.uint64).tolist()


def test_clock_follows_the_scenario_and_labels():
    trk = registry.build("x", {"type": "susi_akf"}, TrackerContext(scenario={"clock": "rubidium"}, tracking=TRACKING, ts=TS))
    assert trk.clock == "rubidium"
    trk = registry.build("x", {"type": "susi_akf"}, TrackerContext(scenario={}, tracking=TRACKING, ts=0.01))
    assert trk.clock == "ocxo" and trk.cn0_window == 50 and trk.n_window == 300
    assert registry.label("x", {"type": "susi_sakf", "gain_weighting": {"alpha": 0.5}}) == "SAKF PLL (alpha = 0.5)"
    assert registry.label("x", {"type": "susi_akf", "clock": "ocxo"}) == "AKF PLL (ocxo)"
