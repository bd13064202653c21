"""The smallest discriminator jitter of a linear causal tracker (scintrack.experiments.prediction_bound).

Independent references written here:

* AR(1): the one-step prediction error variance is the driving noise's
  variance; white noise: its variance;
* random walk plus white noise: the steady-state Kalman predictor from the
  discrete algebraic Riccati equation (``scipy.linalg.solve_discrete_are``):
  innovation variance ``P + r``, filtered error ``P r / (P + r)``;
* a continuous ``T f^-2`` phase sampled at ``fs`` is a random walk whose
  steps have variance ``2 pi^2 T / fs`` (aliasing included);
* the linear third-order loop against the package's PLL tracker on noise-free
  prompts, where the ATAN2 output is the phase error itself.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import solve_discrete_are

from scintrack.errors import InputError
from scintrack.experiments import prediction_bound as pb
from scintrack.models.ar import ar_psd, simulate_ar
from scintrack.trackers.base import TrackInit
from scintrack.trackers.pll import PLL

FS = 1000.0
TS = 1.0 / FS
GRID = np.linspace(0.0, FS / 2, 8193)


def rng(seed: int) -> np.random.Generator:
    return np.random.default_rng(seed)


def kalman_random_walk(q: float, r: float) -> tuple[float, float]:
    """(innovation variance, filtered error variance) of the steady-state Kalman filter of x_k = x_{k-1} + w_k, y_k = x_k + v_k."""
    p = float(solve_discrete_are(np.array([[1.0]]), np.array([[1.0]]), np.array([[q]]), np.array([[r]]))[0, 0])  # prior (predicted) variance
    return p + r, p * r / (p + r)


# --- the formula on exact spectra ----------------------------------------------------------


@pytest.mark.parametrize("a", [0.5, 0.9, 0.99])
def test_ar1_exact_spectrum_gives_the_driving_variance(a):
    sigma2 = 0.37
    one_sided = ar_psd(np.array([a]), sigma2, GRID, FS)  # scipy-welch scaling: twice the two-sided density
    assert pb.kolmogorov_szego(GRID, one_sided, FS, sided="one") == pytest.approx(sigma2, rel=0.02)
    assert pb.kolmogorov_szego(GRID, one_sided / 2, FS) == pytest.approx(sigma2, rel=1e-6)
    # the variance of the process is larger: the formula is not returning the spectrum's integral
    assert 2 * np.trapezoid(one_sided / 2, GRID) == pytest.approx(sigma2 / (1 - a * a), rel=0.02)


def test_white_noise_bound_is_its_variance():
    v = 0.0158
    assert pb.kolmogorov_szego(GRID, np.full(GRID.size, v / FS), FS) == pytest.approx(v, rel=1e-12)
    assert pb.kolmogorov_szego(GRID, np.full(GRID.size, 2 * v / FS), FS, sided="one") == pytest.approx(v, rel=1e-12)
    # thermal noise of one prompt: the package's formula, 1/(2 C/N0 T)
    assert pb.thermal_variance(45.0, TS) == pytest.approx(1.0 / (2 * 10**4.5 * TS))
    assert pb.discriminator_bound(0.0, pb.thermal_variance(45.0, TS)) == pytest.approx(0.1257, abs=1e-4)


@pytest.mark.parametrize("q, r", [(1e-4, 0.0158), (0.01, 0.0158), (0.05, 0.001)])
def test_random_walk_plus_noise_matches_the_kalman_predictor(q, r):
    """Increments of y = random walk + white noise: S_d = (q + r (2 sin(pi f/fs))^2) / fs."""
    innovation, filtered = kalman_random_walk(q, r)
    s = q / FS + pb.white_increment_psd(GRID, r, FS)
    got = pb.kolmogorov_szego(GRID, s, FS)
    assert got == pytest.approx(innovation, rel=1e-6)
    assert pb.filtering_error_variance(got, r) == pytest.approx(filtered, rel=1e-5)
    # without the noise: the random walk's own step variance
    assert pb.kolmogorov_szego(GRID, np.full(GRID.size, q / FS), FS) == pytest.approx(q, rel=1e-9)


def test_sampled_power_law_with_slope_2_is_a_random_walk():
    """One-sided T f^-2 is Brownian motion with diffusion 2 pi^2 T rad^2/s; sampled: steps of 2 pi^2 T / fs."""
    t_strength = 3e-3
    s = pb.power_law_psd(GRID, t_strength, 2.0, FS, f_cut=0.01)
    assert pb.kolmogorov_szego(GRID, s, FS) == pytest.approx(2 * np.pi**2 * t_strength / FS, rel=0.01)
    # the aliases matter: without them the density near fs/2 is too small and so is the variance
    nu = GRID / FS
    alias_free = 0.5 * t_strength * (GRID**2 + 0.01**2) ** -1.0
    assert pb.kolmogorov_szego(GRID, alias_free, FS) < 0.8 * 2 * np.pi**2 * t_strength / FS
    # exact aliased density (pi / (fs sin(pi nu)))^2 away from 0 Hz
    inner = slice(100, None)
    assert np.allclose(s[inner], 0.5 * t_strength * (np.pi / (FS * np.sin(np.pi * nu[inner]))) ** 2, rtol=1e-6)


# --- estimates from a series ----------------------------------------------------------------


@pytest.mark.parametrize("a, difference", [(0.9, 0), (0.9, 1), (0.5, 0)])
def test_ar1_welch_estimate(a, difference):
    sigma2 = 0.37
    x = simulate_ar(np.array([a]), sigma2, 1 << 16, rng(1))
    f, s = pb.increment_psd(x, FS, nperseg=1024, difference=difference)
    assert pb.kolmogorov_szego(f, s, FS) == pytest.approx(sigma2, rel=0.05)
    assert pb.ar_innovation_variance(x, difference=difference)[0] == pytest.approx(sigma2, rel=0.03)


def test_welch_log_bias_correction():
    """White noise, 15 Welch segments: the mean log of the estimate is biased by psi(nu/2) - ln(nu/2) ~ -1/nu;
    over 40 realisations the corrected estimate is unbiased, the uncorrected one is low by that bias."""
    v, n, nperseg = 2.0, 8192, 1024
    k = 1 + (n - nperseg) // (nperseg // 2)
    nu = 2 * k / (1 + 2 * (1 - 1 / k) / 36)  # Hann, 50 % overlap: overlap correlation 1/6 (Percival & Walden)
    bias = pb.welch_log_bias(n, nperseg)
    assert bias == pytest.approx(-1 / nu - 1 / (3 * nu * nu), rel=0.02)  # psi(x) - ln x = -1/(2x) - 1/(12 x^2) + ...
    g = rng(2)
    ratios = []
    for _ in range(40):
        f, s = pb.increment_psd(g.normal(0.0, np.sqrt(v), n), FS, nperseg=nperseg, difference=0)
        ratios.append(pb.kolmogorov_szego(f, s, FS) / v)
    assert np.mean(ratios) == pytest.approx(1.0, abs=0.01)
    assert np.mean(ratios) * np.exp(bias) < 0.98


@pytest.mark.parametrize("q, r", [(1e-3, 0.0158), (0.01, 0.0316)])
def test_spectrum_and_ar_routes_agree_on_random_walk_plus_noise(q, r):
    n = 60000
    g = rng(3)
    y = np.cumsum(g.normal(0.0, np.sqrt(q), n)) + g.normal(0.0, np.sqrt(r), n)
    innovation, _ = kalman_random_walk(q, r)
    f, s = pb.increment_psd(y, FS)
    psd_route = pb.kolmogorov_szego(f, s, FS)
    ar_route, order = pb.ar_innovation_variance(y)
    assert psd_route == pytest.approx(innovation, rel=0.05)
    assert ar_route == pytest.approx(innovation, rel=0.05)
    assert ar_route == pytest.approx(psd_route, rel=0.03)
    assert order >= 1


def test_spectrum_and_ar_routes_agree_on_a_smooth_phase_plus_noise():
    """AR(2) phase with a resonance near 2 Hz, plus thermal noise: both routes, and the exact spectrum."""
    coefs = np.array([2 * 0.995 * np.cos(2 * np.pi * 2 / FS), -0.995**2])
    q, r = 1e-4, 0.0158
    n = 60000
    x = simulate_ar(coefs, q, n, rng(4)) + rng(5).normal(0.0, np.sqrt(r), n)
    exact = pb.kolmogorov_szego(GRID, ar_psd(coefs, q, GRID, FS) / 2 + r / FS, FS)
    f, s = pb.increment_psd(x, FS)
    assert pb.kolmogorov_szego(f, s, FS) == pytest.approx(exact, rel=0.03)
    assert pb.ar_innovation_variance(x)[0] == pytest.approx(exact, rel=0.03)


def test_bad_input():
    with pytest.raises(InputError, match="> 0 everywhere"):
        pb.kolmogorov_szego(GRID, np.zeros(GRID.size), FS)
    with pytest.raises(InputError, match="from 0 to fs/2"):
        pb.kolmogorov_szego(GRID[1:], np.ones(GRID.size - 1), FS)
    with pytest.raises(InputError, match="p > 1"):
        pb.power_law_psd(GRID, 1e-3, 1.0, FS, 0.01)
    with pytest.raises(InputError, match="too few"):
        pb.increment_psd(np.zeros(100), FS)


# --- the third-order loop ------------------------------------------------------------------


def test_linear_loop_is_the_package_pll_on_noise_free_prompts():
    n = 3000
    t = np.arange(n) * TS
    theta = 0.3 * np.sin(2 * np.pi * 1.5 * t) + 0.05 * np.sin(2 * np.pi * 17 * t) + 0.1
    pll = PLL(ts=TS, bandwidth_hz=15.0)
    out = pll.reference(np.exp(1j * theta)[None, :], TrackInit(phase=theta[:1], doppler_hz=np.zeros(1), rate_hz_s=np.zeros(1)))
    mine = pb.linear_pll_errors(theta[None, :], np.zeros((1, n)), 15.0, TS)
    assert np.max(np.abs(out.extras["discriminator"] - mine)) < 1e-9
    assert np.max(np.abs(mine)) > 1e-3  # the loop does lag: the comparison is not between zeros


def test_best_loop_on_thermal_noise_is_the_narrowest():
    n = 20000
    noise = rng(6).standard_normal((2, n))
    sweep = pb.best_third_order_loop(np.zeros(n), 45.0, TS, noise, per_window=5000, start=5000)
    assert sweep.best_bandwidth_hz == pb.BANDWIDTHS_HZ[0]
    assert np.all(np.diff(sweep.jitter_rad) > 0)
    assert sweep.best_jitter_rad == pytest.approx(np.sqrt(pb.thermal_variance(45.0, TS)), rel=0.02)


def test_best_loop_widens_with_a_strong_fast_phase_and_stays_above_the_wiener_bound():
    n = 30000
    q, cn0 = 1e-4, 45.0  # random-walk steps of 0.01 rad per ms: the Kalman predictor is a ~20-Hz first-order loop
    r = pb.thermal_variance(cn0, TS)
    theta = np.cumsum(rng(7).normal(0.0, np.sqrt(q), n))
    noise = rng(8).standard_normal((2, n))
    sweep = pb.best_third_order_loop(theta, cn0, TS, noise, per_window=10000, start=10000)
    thermal = pb.best_third_order_loop(np.zeros(n), cn0, TS, noise, per_window=10000, start=10000)
    assert 15.0 <= sweep.best_bandwidth_hz < pb.BANDWIDTHS_HZ[-1]
    assert thermal.best_bandwidth_hz == pb.BANDWIDTHS_HZ[0]
    wiener = np.sqrt(kalman_random_walk(q, r)[0])
    assert 0.995 * wiener < sweep.best_jitter_rad < 1.05 * wiener
    assert sweep.jitter_rad[0] > 1.2 * sweep.best_jitter_rad  # the 2-Hz loop lags behind


def test_scenario_bound_orders_its_numbers():
    """Prediction bound <= Wiener bound <= best third-order loop; each window's two routes agree."""
    n, per = 3 * 10000, 10000
    g = rng(9)
    phase = np.cumsum(g.normal(0.0, 0.01, n))
    rho = np.ones(n)
    ds = pb.scenario_bound(name="test", phase=phase, amplitude=rho, clock=np.zeros((2, n)), cn0_dbhz=42.0, ts=TS, per_window=per,
                           steady_start=per, noise=g.standard_normal((2, n)))
    assert list(ds["steady"].values) == [False, True, True]
    np.testing.assert_allclose(ds["prediction_var_psd"], 1e-4, rtol=0.05)
    np.testing.assert_allclose(ds["prediction_var_ar"], ds["prediction_var_psd"], rtol=0.05)
    np.testing.assert_allclose(ds["innovation_var_ar"], ds["innovation_var_psd"], rtol=0.05)
    assert float(ds["bound_fading_rad"]) == pytest.approx(float(ds["bound_rad"]))  # rho = 1
    best = ds["best_pll_jitter_rad"].sel(noise_model="nominal")
    assert float(ds["bound_rad"]) < float(ds["wiener_bound_rad"]) < float(best) < 1.05 * float(ds["wiener_bound_rad"])
    assert float(ds["tracking_bound_rad"]) < np.sqrt(float(ds["thermal_var"]))
