"""GPS L1 C/A E/P/L correlator model: statistics, shape, losses, C/N0, determinism, numba = numpy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scintrack.estimators import cn0 as cn0est
from scintrack.seeding import seed_sequence
from scintrack.signals.gps import correlator as corr
from scintrack.signals.gps.correlator import NoiseStream

T1 = 1e-3


def _tri(x):
    return max(0.0, 1.0 - abs(x))


def test_zero_errors_prompt_statistics():
    n = 200_000
    stream = NoiseStream(5, "test-epl", 1.0)
    a = float(corr.amplitude(40.0, T1))
    assert a == pytest.approx(math.sqrt(2 * 1e4 * 1e-3))
    y = corr.open_loop(stream, [0, 1], 3, 0, 40.0, np.ones(n // 2), T1).reshape(-1, 6)
    ip, qp = y[:, 1], y[:, 4]
    # means: standard error 1/sqrt(n); variances: standard error sqrt(2/n)
    assert abs(ip.mean() - a) < 5 / math.sqrt(n)
    assert abs(qp.mean()) < 5 / math.sqrt(n)
    assert abs(ip.var() - 1.0) < 5 * math.sqrt(2 / n)
    assert abs(qp.var() - 1.0) < 5 * math.sqrt(2 / n)
    # E and L see R(+-1/2) = 1/2 of the amplitude at spacing 1
    assert abs(y[:, 0].mean() - a / 2) < 5 / math.sqrt(n)
    assert abs(y[:, 2].mean() - a / 2) < 5 / math.sqrt(n)


@pytest.mark.parametrize("spacing", [1.0, 0.5])
def test_noise_covariance_matches_sigma(spacing):
    n = 200_000
    noise = NoiseStream(1, "test-cov", spacing).epochs([0, 4], 7, 123, 123 + n // 2).reshape(-1, 6)
    sigma = np.array([[_tri(oa - ob) for ob in (spacing / 2, 0, -spacing / 2)] for oa in (spacing / 2, 0, -spacing / 2)])
    np.testing.assert_allclose(corr.noise_covariance(spacing), sigma, rtol=0, atol=1e-15)
    full = np.zeros((6, 6))
    full[:3, :3] = full[3:, 3:] = sigma
    cov = np.cov(noise.T)
    se = np.sqrt((1.0 + full**2) / n)  # Gaussian sample covariance standard error
    assert np.all(np.abs(cov - full) < 5 * se), np.abs(cov - full) / se
    assert np.all(np.abs(noise.mean(axis=0)) < 5 / math.sqrt(n))


def test_sinc_loss_and_mean_phase_at_250_hz():
    a, df = 3.0, 250.0
    y = corr.correlate(a, 1.0, 0.0, 0.0, df, T1, 1.0)
    x = math.pi * df * T1  # pi/4
    loss = math.sin(x) / x
    assert loss == pytest.approx(0.9003163161571061, rel=1e-12)
    assert math.hypot(y[1], y[4]) == pytest.approx(a * loss, rel=1e-12)
    assert math.atan2(y[4], y[1]) == pytest.approx(math.pi / 4, abs=1e-12)
    # independent: mean of a exp(j(dphi + 2 pi df t)) over the interval, dphi = 0.3
    t = (np.arange(200_000) + 0.5) / 200_000 * T1
    ref = a * np.mean(np.exp(1j * (0.3 + 2 * np.pi * df * t)))
    y = corr.correlate(a, 1.0, 0.0, 0.3, df, T1, 1.0)
    assert y[1] == pytest.approx(ref.real, abs=1e-9) and y[4] == pytest.approx(ref.imag, abs=1e-9)
    # first null at df = 1/T
    assert np.allclose(corr.correlate(a, 1.0, 0.0, 0.0, 1000.0, T1, 1.0), 0.0, atol=1e-12)


@pytest.mark.parametrize("spacing", [1.0, 0.5, 0.1])
def test_triangle_shape_and_early_late_sign(spacing):
    a = 2.0
    dtau = np.linspace(-2.0, 2.0, 401)
    y = corr.correlate(a, 1.0, dtau, 0.0, 0.0, T1, spacing)
    for j, o in enumerate((spacing / 2, 0.0, -spacing / 2)):
        np.testing.assert_allclose(y[:, j], [a * _tri(v + o) for v in dtau], atol=1e-14)
    np.testing.assert_allclose(y[:, 3:], 0.0, atol=1e-14)
    inside = (dtau > 0) & (dtau < 1 + spacing / 2)
    assert np.all(y[inside, 2] > y[inside, 0])  # L > E when the replica is early (dtau > 0)
    assert np.all(y[dtau == 0, 0] == y[dtau == 0, 2])
    assert np.all(y[np.abs(dtau) >= 1 + spacing / 2, :3] == 0.0)


def test_phase_rotation_and_data_bit():
    a = 1.5
    for dphi in np.linspace(-3.0, 3.0, 13):
        for d in (1.0, -1.0):
            y = corr.correlate(a, d, 0.2, dphi, 0.0, T1, 1.0)
            r = np.array([_tri(0.7), _tri(0.2), _tri(-0.3)])
            np.testing.assert_allclose(y[:3], d * a * math.cos(dphi) * r, atol=1e-14)
            np.testing.assert_allclose(y[3:], d * a * math.sin(dphi) * r, atol=1e-14)


def _prompts(y):
    return y[..., 1] + 1j * y[..., 4]


@pytest.mark.parametrize("cn0_dbhz", [45.0, 15.0])
def test_m2m4_recovers_cn0(cn0_dbhz):
    """M2M4 on generated prompts: 0.3 dB at T = 20 ms (sum of 20 epochs) and, at 45 dB-Hz, T = 1 ms.

    Sample sizes: the M2M4 dB estimate has a standard deviation of ~0.24 dB per
    sqrt(20000 / N) at 15 dB-Hz, T = 20 ms (N 20-ms samples) and ~0.044 dB at
    45 dB-Hz with N = 20000; 240000 and 30000 samples put 0.3 dB beyond 4 sigma.
    At 15 dB-Hz and T = 1 ms (C/N0 T = 0.03) M2M4 would need ~1e9 samples for
    0.3 dB, so there the test checks the second moment E|P|^2 = a^2 + 2 instead.
    """
    rng_trials = list(range(40)) if cn0_dbhz < 30 else list(range(4))
    n = 120_000 if cn0_dbhz < 30 else 150_000
    bits = np.repeat(np.where(np.arange(n // 20) % 3 == 0, -1.0, 1.0), 20)  # 20-ms data bits
    stream = NoiseStream(2024, "test-m2m4", 1.0)
    y = corr.open_loop(stream, rng_trials, 11, 40, cn0_dbhz, bits, T1)
    p1 = _prompts(y)
    if cn0_dbhz > 30:
        pd, pn = cn0est.m2m4(p1.ravel())
        assert cn0est.to_dbhz(cn0est.cn0_from_powers(pd, pn, T1)) == pytest.approx(cn0_dbhz, abs=0.3)
    else:
        a2 = 2 * 10 ** (cn0_dbhz / 10) * T1
        m2 = np.mean(np.abs(p1) ** 2)
        # var |P|^2 = 4 + 4 a^2 for unit noise per component
        assert abs(m2 - (a2 + 2.0)) < 4.5 * math.sqrt((4 + 4 * a2) / p1.size)
        assert 10 * np.log10((m2 - 2.0) / (2 * T1)) == pytest.approx(cn0_dbhz, abs=0.3)
    p20 = p1.reshape(len(rng_trials), n // 20, 20).sum(axis=-1)  # coherent 20 ms, bits aligned
    pd, pn = cn0est.m2m4(p20.ravel())
    assert cn0est.to_dbhz(cn0est.cn0_from_powers(pd, pn, 20 * T1)) == pytest.approx(cn0_dbhz, abs=0.3)


def test_fixed_gain_has_the_same_snr_as_agc():
    a_agc, s_agc = corr.gains(np.array([45.0, 20.0]), T1)
    a_fix, s_fix = corr.gains(np.array([45.0, 20.0]), T1, "fixed", cn0_ref_dbhz=45.0)
    np.testing.assert_allclose(s_agc, 1.0)
    np.testing.assert_allclose(a_fix, corr.amplitude(45.0, T1))
    np.testing.assert_allclose(s_fix, [1.0, 10 ** (25 / 20)])
    np.testing.assert_allclose((a_fix / s_fix) ** 2, (a_agc / s_agc) ** 2, rtol=1e-12)
    # the noise is scaled by sigma in both paths
    noise = NoiseStream(3, "test-gain", 1.0).epochs([0], 0, 0, 20_000)[0]
    y = corr.correlate(a_fix[1], 1.0, 0.0, 0.0, 0.0, T1, 1.0, noise, s_fix[1])
    assert np.std(y[:, 4]) == pytest.approx(s_fix[1], rel=5 * math.sqrt(0.5 / 20_000))
    with pytest.raises(ValueError, match="cn0_ref_dbhz"):
        corr.gains(30.0, T1, "fixed")


def test_noise_is_a_function_of_seed_trial_sv_epoch_only():
    s = NoiseStream(9, "test-det", 0.5, block=100)
    ref = {tr: np.concatenate([s.block(tr, 28, k) for k in range(6)]) for tr in (0, 1, 2, 5)}
    rev = {tr: np.concatenate([s.block(tr, 28, k) for k in reversed(range(6))][::-1]) for tr in (5, 2, 1, 0)}
    for tr in ref:
        assert np.array_equal(ref[tr], rev[tr])
    batch = s.epochs([5, 0, 2], 28, 37, 555)
    assert np.array_equal(batch[0], ref[5][37:555]) and np.array_equal(batch[1], ref[0][37:555])
    assert np.array_equal(s.epochs([2], 28, 37, 555)[0], batch[2])
    assert np.array_equal(s.epochs(1, 28, 0, 600)[0], ref[1])
    # a fresh stream object with the same seed and name reproduces it; another sv, trial or seed does not
    assert np.array_equal(NoiseStream(9, "test-det", 0.5, block=100).epochs([2], 28, 300, 310)[0], ref[2][300:310])
    assert not np.allclose(s.epochs([2], 30, 0, 600)[0], ref[2])
    assert not np.allclose(NoiseStream(10, "test-det", 0.5, block=100).epochs([2], 28, 0, 600)[0], ref[2])
    assert not np.allclose(ref[0], ref[1])
    # block k of (trial, sv) is the grandchild (sv, k) of the project's per-trial SeedSequence
    child = seed_sequence(9, "test-det", 2).spawn(29)[28].spawn(4)[3]
    assert np.array_equal(s.seed_sequence(2, 28, 3).generate_state(4), child.generate_state(4))
    out = np.empty((2, 99, 6))
    assert s.epochs([0, 1], 28, 1, 100, out=out) is out and np.array_equal(out[1], ref[1][1:100])


def test_numba_scalar_path_equals_numpy_wrapper():
    rng = np.random.default_rng(4)
    n = 2000
    a = rng.uniform(0.0, 20.0, n)
    d = rng.choice([-1.0, 1.0], n)
    dtau = rng.uniform(-1.5, 1.5, n)
    dphi = rng.uniform(-4.0, 4.0, n)
    df = rng.uniform(-600.0, 600.0, n)
    df[:5] = 0.0
    sigma = rng.uniform(0.5, 3.0, n)
    noise = NoiseStream(1, "test-numba", 0.5).epochs([0], 1, 0, n)[0]
    ref = corr.correlate(a, d, dtau, dphi, df, T1, 0.5, noise, sigma)
    out = np.empty(6)
    for k in range(n):
        corr.epl(a[k], d[k], dtau[k], dphi[k], df[k], T1, 0.5, noise[k], out, sigma[k])
        np.testing.assert_allclose(out, ref[k], rtol=0, atol=1e-12)
    corr.epl(a[0], d[0], dtau[0], dphi[0], df[0], T1, 0.5, noise[0], out)  # sigma defaults to 1
    np.testing.assert_allclose(out, corr.correlate(a[0], d[0], dtau[0], dphi[0], df[0], T1, 0.5, noise[0]), atol=1e-12)


def test_correlate_broadcasts_over_leading_shapes():
    noise = np.zeros((3, 4, 6))
    y = corr.correlate(np.full((3, 1), 2.0), 1.0, np.linspace(-0.5, 0.5, 4), 0.0, 0.0, T1, 1.0, noise)
    assert y.shape == (3, 4, 6)
    assert corr.correlate(1.0, 1.0, 0.0, 0.0, 0.0, T1, 1.0).shape == (6,)


def test_bad_input():
    with pytest.raises(ValueError, match="spacing_chips"):
        NoiseStream(1, "x", 0.0)
    with pytest.raises(ValueError, match="block"):
        NoiseStream(1, "x", 1.0, block=0)
    with pytest.raises(ValueError, match="seed"):
        NoiseStream(-1, "x", 1.0)
    s = NoiseStream(1, "x", 1.0)
    with pytest.raises(ValueError, match="k0"):
        s.epochs([0], 1, 10, 5)
    with pytest.raises(ValueError, match="trial"):
        s.block(-1, 1, 0)
    with pytest.raises(ValueError, match="noise"):
        corr.correlate(1.0, 1.0, 0.0, 0.0, 0.0, T1, 1.0, np.zeros(4))
    with pytest.raises(ValueError, match="bits"):
        corr.open_loop(s, [0], 1, 0, 40.0, np.zeros(10), T1)
    with pytest.raises(ValueError, match="gain mode"):
        corr.gains(40.0, T1, "manual")
    with pytest.raises(ValueError, match="T"):
        corr.amplitude(40.0, 0.0)
