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
