"""Clock h-coefficient models: units, exact Q, Zhao eq. (3), simulation vs Allan variance."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.linalg import expm

from scintrack.models import clock
from scintrack.models.clock import F_L1_HZ, PRESETS, ClockModel

C = 299_792_458.0


def test_zhao_coefficients_are_fractional_h_times_fl1_squared():
    assert 4.9639e-3 / F_L1_HZ**2 == pytest.approx(2.0000e-21, rel=1e-5)
    assert 7.4458e-6 / F_L1_HZ**2 == pytest.approx(3.0000e-24, rel=1e-5)
    z = PRESETS["zhao_tcxo"]
    # the cycles-unit Q uses the paper's numbers exactly: S_f = h0/2, S_g = 2 pi^2 h_-2 (eqs. 4-5)
    dt = 0.02
    sf, sg = 4.9639e-3 / 2.0, 2.0 * math.pi**2 * 7.4458e-6
    expected = np.array([[sf * dt + sg * dt**3 / 3, sg * dt**2 / 2], [sg * dt**2 / 2, sg * dt]])
    np.testing.assert_allclose(clock.process_noise(z, dt, "cycles"), expected, rtol=1e-12)


def test_documented_random_walk_magnitudes():
    z = PRESETS["zhao_tcxo"]
    assert math.sqrt(clock.process_noise(z, 0.001)[0, 0]) == pytest.approx(1.58e-3, rel=5e-3)
    assert math.sqrt(clock.process_noise(z, 0.02)[0, 0]) == pytest.approx(7.05e-3, rel=5e-3)
    assert math.sqrt(clock.process_noise(z, 0.02, "rad")[0, 0]) == pytest.approx(0.0443, rel=5e-3)
    assert math.sqrt(clock.process_noise(z, 1.0)[1, 1]) == pytest.approx(0.0121, rel=5e-3)
    assert math.sqrt(clock.process_noise(z, 240.0)[1, 1]) == pytest.approx(0.188, rel=5e-3)
    assert math.sqrt(clock.process_noise(z, 240.0)[0, 0]) == pytest.approx(26.0, rel=5e-3)


@pytest.mark.parametrize("name", sorted(PRESETS))
@pytest.mark.parametrize("dt", [1e-3, 0.02, 1.0, 100.0])
def test_q_symmetric_psd_and_equals_van_loan(name, dt):
    m = PRESETS[name]
    q = clock.process_noise(m, dt, "s")
    assert np.array_equal(q, q.T)
    assert np.all(np.linalg.eigvalsh(q / q[0, 0]) >= -1e-12)
    # Van Loan: continuous x' = y + w_f, y' = w_g, Qc = diag(S_f, S_g)
    F = np.array([[0.0, 1.0], [0.0, 0.0]])
    Qc = np.diag([m.h0 / 2.0, 2.0 * math.pi**2 * m.h_m2])
    M = np.block([[-F, Qc], [np.zeros((2, 2)), F.T]]) * dt
    E = expm(M)
    phi = E[2:, 2:].T
    q_vl = phi @ E[:2, 2:]
    np.testing.assert_allclose(phi, clock.transition(dt), rtol=0, atol=1e-12 * dt)
    np.testing.assert_allclose(q, q_vl, rtol=1e-9, atol=0)
    assert np.linalg.det(q) > 0 and np.all(np.diag(q) > 0)


def test_units_are_consistent():
    m = PRESETS["tcxo_high"]
    dt = 0.01
    cyc = clock.process_noise(m, dt, "cycles")
    np.testing.assert_allclose(clock.process_noise(m, dt, "rad"), (2 * math.pi) ** 2 * cyc, rtol=1e-14)
    np.testing.assert_allclose(clock.process_noise(m, dt, "s") * F_L1_HZ**2, cyc, rtol=1e-14)
    np.testing.assert_allclose(clock.process_noise(m, dt, "m"), cyc * (C / F_L1_HZ) ** 2, rtol=1e-14)
    np.testing.assert_allclose(clock.process_noise(m, dt, "cycles", carrier_hz=1176.45e6), cyc * (1176.45e6 / F_L1_HZ) ** 2, rtol=1e-14)
    p_c, f_c = clock.simulate(m, dt, 50, 7, "cycles")
    p_r, f_r = clock.simulate(m, dt, 50, 7, "rad")
    p_m, f_m = clock.simulate(m, dt, 50, 7, "m")
    np.testing.assert_allclose(p_r, 2 * math.pi * p_c, rtol=1e-12)
    np.testing.assert_allclose(f_r, 2 * math.pi * f_c, rtol=1e-12)
    np.testing.assert_allclose(p_m, C / F_L1_HZ * p_c, rtol=1e-12)
    np.testing.assert_allclose(f_m, C / F_L1_HZ * f_c, rtol=1e-12)


def test_zhao_eq3_as_written():
    z = PRESETS["zhao_tcxo"]
    for dt in (0.001, 0.02):
        sf, sg = 4.9639e-3 / 2.0, 2.0 * math.pi**2 * 7.4458e-6
        w = np.array([[sf * dt + sg * dt**3 / 3, sg * dt**2 / 2], [sg * dt**2 / 2, sf / dt + 4.0 / 3.0 * sg * dt]])
        np.testing.assert_allclose(clock.process_noise_zhao_eq3(z, dt), w, rtol=1e-12)
        exact = clock.process_noise(z, dt)
        np.testing.assert_allclose(clock.process_noise_zhao_eq3(z, dt)[:, 0], exact[:, 0], rtol=1e-14)
        assert clock.process_noise_zhao_eq3(z, dt)[1, 1] > exact[1, 1]


def test_first_step_covariance_matches_q():
    m = PRESETS["tcxo_low"]
    dt, n = 0.5, 200_000
    phase, freq = clock.simulate(m, dt, 2, np.random.default_rng(3), "cycles", trials=n)
    assert phase.shape == (n, 2) and np.all(phase[:, 0] == 0) and np.all(freq[:, 0] == 0)
    q = clock.process_noise(m, dt, "cycles")
    cov = np.cov(np.stack([phase[:, 1], freq[:, 1]]))
    # sample covariance entry (a, b) has standard error sqrt((q_aa q_bb + q_ab^2) / n) for Gaussian data
    se = np.sqrt((np.outer(np.diag(q), np.diag(q)) + q**2) / n)
    assert np.all(np.abs(cov - q) < 5 * se)


def _overlapping_avar(x: np.ndarray, m: int, dt: float) -> np.ndarray:
    """Overlapping Allan variance from time-deviation samples x (s), along the last axis."""
    d2 = x[..., 2 * m :] - 2 * x[..., m:-m] + x[..., : -2 * m]
    return np.mean(d2**2, axis=-1) / (2 * (m * dt) ** 2)


@pytest.mark.parametrize(
    "model, dt, ms",
    [
        (PRESETS["zhao_tcxo"], 1e-3, (1, 10, 100)),  # white FM dominates below ~7 s
        (PRESETS["tcxo_low"].without_flicker(), 1.0, (4, 16, 64)),  # random-walk FM dominates above ~1 s
    ],
)
def test_simulated_allan_variance_matches_closed_form(model, dt, ms):
    trials, n = 200, 2000
    x, _ = clock.simulate(model, dt, n, np.random.SeedSequence(11), "s", trials=trials)
    for m in ms:
        tau = m * dt
        per_trial = _overlapping_avar(x, m, dt)
        mean, se = per_trial.mean(), per_trial.std(ddof=1) / math.sqrt(trials)
        theory = clock.allan_variance(model, tau)
        assert se < 0.06 * theory  # the test can resolve a wrong S_f or S_g (factor 2 = 100 %)
        assert abs(mean - theory) < 4.5 * se, (tau, mean, theory, se)
    # the dominant term really is the one named
    h0_term, rw_term = model.h0 / (2 * ms[-1] * dt), 2 * math.pi**2 / 3 * model.h_m2 * ms[-1] * dt
    assert (h0_term > 10 * rw_term) if dt < 0.1 else (rw_term > 10 * h0_term)


@pytest.mark.parametrize("name", ["tcxo_low", "ocxo", "rubidium"])
def test_allan_variance_closed_form_equals_spectral_integral(name):
    """sigma_y^2(tau) = 2 int_0^inf S_y(f) sin^4(pi f tau) / (pi f tau)^2 df, S_y one-sided."""
    m = PRESETS[name]
    tau = 0.7
    # substitute u = pi f tau: sigma^2 = 2/(pi tau) int S_y(u/(pi tau)) sin^4 u / u^2 du; tails beyond U analytic
    U = 400.0

    def integral(power, tail):
        val, _ = quad(lambda u: math.sin(u) ** 4 / u ** (2 + power), 0.0, U, limit=2000)
        return val + tail

    i0 = integral(0, 3.0 / (8.0 * U))  # mean of sin^4 = 3/8
    i1 = integral(1, 3.0 / (16.0 * U**2))
    i2 = integral(2, 3.0 / (8.0 * 3.0 * U**3))
    pt = math.pi * tau
    numeric = 2.0 / pt * (m.h0 * i0 + m.h_m1 * pt * i1 + m.h_m2 * pt**2 * i2)
    assert numeric == pytest.approx(float(clock.allan_variance(m, tau)), rel=1e-4)


def test_bad_input():
    with pytest.raises(ValueError, match="units"):
        clock.process_noise(PRESETS["ocxo"], 0.01, "furlongs")
    with pytest.raises(ValueError, match="dt"):
        clock.process_noise(PRESETS["ocxo"], 0.0)
    with pytest.raises(ValueError, match="h_m2"):
        ClockModel(1e-21, 0.0, -1.0)
    with pytest.raises(ValueError, match="unknown clock preset"):
        clock.preset("quartz")
    with pytest.raises(ValueError, match="rng_or_seed"):
        clock.simulate(PRESETS["ocxo"], 0.01, 10, "seed")
    with pytest.raises(ValueError, match="tau"):
        clock.allan_variance(PRESETS["ocxo"], [1.0, -1.0])
    assert clock.preset("ocxo") is PRESETS["ocxo"]


def test_zero_noise_model_simulates_zeros():
    x, y = clock.simulate(ClockModel(0.0, 0.0, 0.0), 0.01, 5, 0, trials=3)
    assert np.all(x == 0) and np.all(y == 0)
