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
