"""C/N0 (M2M4) and S4 estimators recover known values."""

from __future__ import annotations

import numpy as np
import pytest

from scintrack.estimators.cn0 import StreamingM2M4, cn0_from_powers, m2m4, to_dbhz
from scintrack.estimators.s4 import StreamingS4, s4_batch
from scintrack.signals.correlator import complex_noise, noise_power
from scintrack.signals.csm import generate_csm

TS = 0.01


@pytest.mark.parametrize("cn0_dbhz", [25.0, 30.0, 40.0])
def test_m2m4_recovers_cn0(cn0_dbhz):
    s2 = noise_power(cn0_dbhz, TS)
    n = complex_noise(1, "cn0", range(4), 20_000, s2)
    y = np.exp(1j * np.linspace(0, 300, 20_000)) + n  # phase-insensitive
    sig, noi = m2m4(y)
    est = to_dbhz(cn0_from_powers(sig, noi, TS))
    assert np.all(np.abs(est - cn0_dbhz) < 0.5), est


def test_streaming_m2m4_matches_batch_over_its_window():
    y = np.exp(0.3j) + complex_noise(2, "s", range(3), 500, 0.1)
    est = StreamingM2M4(3, 100, prior_signal=1.0, prior_noise=0.1)
    for k in range(500):
        sig, noi = est.update(y[:, k])
    bs, bn = m2m4(y[:, -100:])
    np.testing.assert_allclose(sig, bs, rtol=1e-9)
    np.testing.assert_allclose(noi, bn, rtol=1e-9)


@pytest.mark.parametrize("s4", [0.3, 0.6, 0.9])
def test_s4_estimator_with_noise_correction(s4):
    z = generate_csm(seed=3, name=f"s4est-{s4}", trials=range(8), n_epochs=30_000, ts=TS, s4=s4, tau0=0.2, warmup=500).z
    s2 = noise_power(30.0, TS)
    y = z + complex_noise(3, "s4noise", range(8), 30_000, s2)
    est = s4_batch(y.ravel(), s2)
    assert abs(float(est) - s4) < 0.04, est
    raw = np.sqrt(np.var(np.abs(y.ravel()) ** 2)) / np.mean(np.abs(y.ravel()) ** 2)
    assert raw > est  # the correction removes the thermal-noise contribution


def test_streaming_s4_returns_prior_until_window_fills():
    est = StreamingS4(2, 50, prior=0.7, min_epochs=20)
    y = np.ones(2, dtype=complex)
    for _ in range(19):
        out = est.update(y, np.zeros(2))
    assert np.all(out == 0.7)
    out = est.update(y, np.zeros(2))
    assert np.allclose(out, 0.0)


def test_every_s4_lives_in_estimators_s4_and_agrees():
    from scintrack.estimators import s4 as s4mod
    from scintrack.signals import csm, phase_screen

    assert csm.s4_index is s4mod.s4_index and phase_screen.window_s4 is s4mod.window_s4
    z = generate_csm(seed=4, name="s4all", trials=range(2), n_epochs=20_000, ts=TS, s4=0.7, tau0=0.2, warmup=500).z
    raw = s4mod.s4_index(z)
    np.testing.assert_allclose(raw, s4mod.s4_batch(z, 0.0), rtol=1e-9)  # no noise: the correction is the identity
    intensity = np.abs(z[0]) ** 2
    per_window = s4mod.window_s4(intensity, 5000)
    assert per_window.shape == (4,)
    np.testing.assert_allclose(per_window, [np.std(b) / np.mean(b) for b in intensity.reshape(4, 5000)], rtol=1e-12)


def test_streaming_s4_equals_the_correction_of_its_window_moments():
    y = 0.9 * np.exp(0.2j) * (1 + 0.3 * np.sin(np.arange(400) / 7.0)) + complex_noise(8, "s4s", range(2), 400, 0.05)
    est = StreamingS4(2, 100, min_epochs=100)
    for k in range(400):
        out = est.update(y[:, k], np.full(2, 0.05))
    i = np.abs(y[:, -100:]) ** 2
    from scintrack.estimators.s4 import s4_corrected

    np.testing.assert_allclose(out, s4_corrected(i.mean(axis=1), i.var(axis=1), 0.05), rtol=1e-9)


def test_numba_blocks_and_their_array_forms_are_one_formula():
    from scintrack.trackers import blocks

    rng = np.random.default_rng(1)
    m2, m4 = 1 + rng.random(50), 1 + 3 * rng.random(50)
    pd = blocks.m2m4_signal_power_ufunc(m2, m4, 1e-3)
    assert np.array_equal(pd, [blocks.m2m4_split(a, b, 1e-3)[0] for a, b in zip(m2, m4)])
    cn0 = 10 ** rng.uniform(1, 5, 50)
    assert np.array_equal(blocks.atan_variance_ufunc(cn0, TS), [blocks.atan_variance(c, TS) for c in cn0])
    mean, var, s2 = 1 + rng.random(50), rng.random(50), 0.1 * rng.random(50)
    assert np.array_equal(blocks.s4_corrected_ufunc(mean, var, s2), [blocks.s4_corrected(a, b, c) for a, b, c in zip(mean, var, s2)])
    # the M2M4 split: signal = sqrt(2 m2^2 - m4) for a noiseless constant envelope plus known noise
    a2, s2_ = 2.0, 0.3
    sig, noi = blocks.m2m4_split(a2 + s2_, a2**2 + 4 * a2 * s2_ + 2 * s2_**2, 1e-3)
    assert abs(sig - a2) < 1e-12 and abs(noi - s2_) < 1e-12
