"""AR fitting, PACF order selection and AR spectra (statsmodels/scipy based)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from scintrack.models.ar import ar_psd, fit_ar, fit_orders, ic_order, pacf_order, pacf_with_bound, simulate_ar
from scintrack.seeding import rng_for

TRUE = np.array([0.6, -0.4, 0.3])


@pytest.fixture(scope="module")
def ar3_series():
    return simulate_ar(TRUE, 0.5, 40_000, rng_for(1, "ar3", 0), const=0.2)


def test_fit_recovers_coefficients_constant_and_variance(ar3_series):
    fit = fit_ar(ar3_series, 3, "c")
    np.testing.assert_allclose(fit.coefs, TRUE, atol=0.02)
    assert abs(fit.sigma2 - 0.5) < 0.02
    assert abs(fit.mean - 0.2 / (1 - TRUE.sum())) < 0.05


def test_fit_without_constant_near_unit_root():
    x = simulate_ar(np.array([0.995]), 1e-3, 50_000, rng_for(1, "ar1", 0))
    fit = fit_ar(x, 1, "n")
    assert abs(fit.coefs[0] - 0.995) < 0.003
    assert fit.const == 0.0


def test_pacf_rule_picks_the_true_order(ar3_series):
    values, bound = pacf_with_bound(ar3_series, 10)
    assert np.allclose(bound[1:], 1.959964 / np.sqrt(ar3_series.size), rtol=1e-3)
    assert pacf_order(values, bound) == 3


@pytest.mark.parametrize("ic", ["aic", "bic"])
def test_information_criteria_pick_the_true_order(ar3_series, ic):
    assert ic_order(fit_orders(ar3_series, 8, "c"), ic) == 3


def test_pacf_order_rule_on_crafted_values():
    bound = np.full(6, 0.1)
    assert pacf_order(np.array([1, 0.9, -0.5, 0.05, 0.3, 0.0]), bound) == 2
    assert pacf_order(np.array([1, 0.05, 0.5, 0.5, 0.5, 0.5]), bound) == 0
    assert pacf_order(np.array([1, 0.5, 0.5, 0.5, 0.5, 0.5]), bound) == 5


def test_ar_psd_matches_welch_of_simulated_process(ar3_series):
    fit = fit_ar(ar3_series, 3, "c")
    f, pxx = signal.welch(ar3_series, fs=100.0, nperseg=1024)
    model = ar_psd(fit.coefs, fit.sigma2, f, 100.0)
    # Parseval: both integrate to the process variance; shapes agree in dB.
    assert abs(np.trapezoid(model, f) / np.var(ar3_series) - 1) < 0.03
    assert np.median(np.abs(10 * np.log10(pxx[1:] / model[1:]))) < 0.5


def test_bad_series_are_rejected():
    with pytest.raises(ValueError, match="NaN"):
        fit_ar(np.array([1.0, np.nan] * 100), 2, "c")
    with pytest.raises(ValueError, match="too few"):
        fit_ar(np.arange(10.0), 3, "c")


def test_one_ar_type_from_fit_to_tracker_and_simulation():
    """ScintillationAR (the trackers' pair of ArModel) simulates with the one
    simulator; refitting recovers both models."""
    from scintrack.models.ar import ArModel, ScintillationAR

    pair = ScintillationAR.from_coefs([0.95], [1.2, -0.3], kappa=0.1, sigma2_theta=1e-3, sigma2_rho=1e-3, s4=0.6)
    assert isinstance(pair.phase, ArModel) and pair.amplitude.order == 2
    assert abs(pair.rho_mean - 0.1 / (1 - 0.9)) < 1e-12 and abs(pair.amplitude.mean - pair.rho_mean) < 1e-12
    theta, rho = pair.simulate(60_000, rng_for(2, "pair", 0), burn=2000)
    assert abs(rho.mean() - pair.rho_mean) < 0.05
    ph, am = fit_ar(theta, 1, "n"), fit_ar(rho, 2, "c")
    np.testing.assert_allclose(ph.coefs, [0.95], atol=0.01)
    np.testing.assert_allclose(am.coefs, [1.2, -0.3], atol=0.02)
    assert abs(am.const - 0.1) < 0.01 and abs(am.sigma2 - 1e-3) < 1e-4
    # same draws as the bare simulator (one generator: phase first, then amplitude)
    rng = rng_for(2, "pair", 0)
    th2 = simulate_ar([0.95], 1e-3, 60_000, rng, burn=2000)
    np.testing.assert_array_equal(theta, th2)
    assert ScintillationAR.no_scintillation().rho_mean == 1.0  # unit root: the tracker starts at 1


def test_lut_lookup_returns_the_one_type():
    import xarray as xr

    from scintrack.models.ar import ArModel
    from scintrack.models.lut import lookup, scintillation_ar

    coef = np.zeros((2, 1, 2, 3, 3))
    coef[:, 0, 0, 2, :3] = [1.8, -0.9, 0.05]
    coef[0, 0, 1, 1, :2] = [1.9, -0.91]  # S4 = 0.5 (moderate): phase AR(2)
    coef[1, 0, 1, 0, :1] = [0.99]  # S4 = 0.9 (severe): phase AR(1)
    lut = xr.Dataset(
        {
            "coef": (("s4", "tau0", "component", "order", "lag"), coef),
            "const": (("s4", "tau0", "component", "order"), np.full((2, 1, 2, 3), 0.05)),
            "sigma2": (("s4", "tau0", "component", "order"), np.full((2, 1, 2, 3), 1e-3)),
        },
        coords={"s4": [0.5, 0.9], "tau0": [0.4], "component": ["amplitude", "phase"], "order": [1, 2, 3], "lag": [1, 2, 3]},
    )
    assert isinstance(lookup(lut, 0.5, 0.4, "amplitude", 3), ArModel)
    severe, moderate = scintillation_ar(lut, 0.8, 0.2), scintillation_ar(lut, 0.45, 0.4)
    np.testing.assert_array_equal(severe.phase.coefs, [0.99])
    np.testing.assert_array_equal(moderate.phase.coefs, [1.9, -0.91])
    assert (severe.s4, severe.tau0, moderate.s4) == (0.9, 0.4, 0.5)
    np.testing.assert_array_equal(severe.amplitude.coefs, [1.8, -0.9, 0.05])


@pytest.mark.parametrize("trend", ["n", "c"])
def test_fits_are_autoregs_bit_for_bit(trend):
    """fit_orders / fit_ar compute AutoReg's fit from statsmodels' pieces (one design per series): parameters,
    sigma2, AIC and BIC equal AutoReg(x, order, trend, hold_back).fit()'s as uint64, for series of several
    lengths, scales and offsets (a near-unit root, a white series, an AR(3) with a mean)."""
    from statsmodels.tsa.ar_model import AutoReg

    def bits(v):
        return np.atleast_1d(np.asarray(v, dtype=float)).view(np.uint64)

    for case in range(6):
        rng = rng_for(3, "autoreg", case)
        n = (30_000, 301, 3001, 1000, 12_345, 500)[case]
        x = [simulate_ar(np.array([0.999]), 1e-4, n, rng), rng.normal(0.0, 3.0, n), simulate_ar(TRUE, 0.5, n, rng, const=0.2)][case % 3]
        x = x * 10.0 ** (case - 3) + (0.0 if case % 2 else 1.5)
        mine = fit_orders(x, 8, trend)
        single = [fit_ar(x, 2, trend), fit_ar(x, 5, trend, hold_back=7)]
        for fit, (order, hold) in zip(mine + single, [(o, 8) for o in range(1, 9)] + [(2, None), (5, 7)]):
            ref = AutoReg(x, lags=order, trend=trend, hold_back=hold).fit()
            params = np.asarray(ref.params, dtype=float)
            want = (params[1:], params[0]) if trend == "c" else (params, 0.0)
            assert np.array_equal(bits(fit.coefs), bits(want[0])) and bits(fit.const) == bits(want[1]), (case, order)
            for name in ("sigma2", "aic", "bic"):
                assert bits(getattr(fit, name)) == bits(getattr(ref, name)), (case, order, name)
