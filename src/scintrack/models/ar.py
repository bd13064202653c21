"""AR(q) amplitude and AR(p) phase scintillation models (Vila-Valls 2018, Sec. III).

Fitting, partial autocorrelation and order selection all come from
statsmodels; nothing here re-implements Yule-Walker or the PACF.

* Amplitude, eq. (3): ``rho_k = sum_i gamma_i rho_{k-i} + kappa + eta_rho``,
  fitted with a constant (``trend="c"``).
* Phase, eq. (4): ``theta_k = sum_i beta_i theta_{k-i} + eta_theta``, fitted
  without a constant (``trend="n"``) on the unwrapped phase.

Estimator: conditional maximum likelihood (OLS) through
``statsmodels.tsa.ar_model.AutoReg``.  We prefer it to Yule-Walker because the
severe-scintillation phase has a root close to 1, where Yule-Walker is biased
towards stationarity.

Order selection from the PACF ("as the paper does"): the order is the last lag
of the initial run of lags whose partial autocorrelation lies outside the 95%
band ``+-z_{0.975}/sqrt(N)`` that statsmodels returns (i.e. the first lag
*inside* the band, minus one).  AIC and BIC orders minimise statsmodels' own
AutoReg AIC/BIC over AR(1..max_order) fitted on a common sample.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from statsmodels.tsa.ar_model import AutoReg
from statsmodels.tsa.stattools import pacf

TRENDS = {"amplitude": "c", "phase": "n"}


@dataclass(frozen=True)
class ArFit:
    """One fitted AR model: ``x_k = sum coefs[i] x_{k-1-i} + const + e_k``."""

    coefs: np.ndarray
    const: float
    sigma2: float
    aic: float
    bic: float

    @property
    def order(self) -> int:
        return int(self.coefs.size)

    @property
    def mean(self) -> float:
        """Process mean ``kappa / (1 - sum gamma_i)`` (nan for a unit root)."""
        denom = 1.0 - float(np.sum(self.coefs))
        return self.const / denom if abs(denom) > 1e-12 else float("nan")


def _check_series(x: np.ndarray, order: int) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise ValueError("AR fitting expects a 1-D series")
    if not np.all(np.isfinite(x)):
        raise ValueError("AR fitting: the series contains NaN or inf")
    if x.size < 10 * max(order, 1):
        raise ValueError(f"AR fitting: {x.size} samples are too few for order {order}")
    return x


def fit_ar(x: np.ndarray, order: int, trend: str, hold_back: int | None = None) -> ArFit:
    """Fit AR(``order``) by conditional ML (OLS) with statsmodels' ``AutoReg``.

    ``hold_back`` (>= order) drops that many initial observations, so that fits
    of different orders share one estimation sample and their AIC/BIC compare.
    """
    if order < 1:
        raise ValueError("AR order must be >= 1")
    x = _check_series(x, max(order, hold_back or 0))
    res = AutoReg(x, lags=order, trend=trend, hold_back=hold_back).fit()
    params = np.asarray(res.params, dtype=float)
    if trend == "c":
        const, coefs = float(params[0]), params[1:]
    elif trend == "n":
        const, coefs = 0.0, params
    else:
        raise ValueError(f"trend must be 'c' or 'n', got {trend!r}")
    return ArFit(coefs=coefs.copy(), const=const, sigma2=float(res.sigma2), aic=float(res.aic), bic=float(res.bic))


def pacf_with_bound(x: np.ndarray, nlags: int, alpha: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """Sample PACF at lags 0..nlags and the half-width of its (1-alpha) band around 0.

    Both come from ``statsmodels.tsa.stattools.pacf(method="ols", alpha=...)``;
    the band half-width is the distance from the estimate to its confidence
    limit, ``z_{1-alpha/2}/sqrt(N)``.
    """
    x = _check_series(x, nlags)
    values, confint = pacf(x, nlags=nlags, alpha=alpha, method="ols")
    bound = confint[:, 1] - values
    return np.asarray(values), np.asarray(bound)


def pacf_order(values: np.ndarray, bound: np.ndarray) -> int:
    """Order from the PACF: the first lag >= 1 inside the band, minus one.

    ``values`` and ``bound`` are indexed by lag (lag 0 first).  If every lag
    up to the last one computed is outside the band, the last lag is returned.
    """
    inside = np.abs(values[1:]) <= bound[1:]
    if not inside.any():
        return int(values.size - 1)
    return int(np.argmax(inside))


def fit_orders(x: np.ndarray, max_order: int, trend: str) -> list[ArFit]:
    """AR(1..max_order) fitted on one common sample (``hold_back=max_order``)."""
    return [fit_ar(x, order, trend, hold_back=max_order) for order in range(1, max_order + 1)]


def ic_order(fits: list[ArFit], ic: str) -> int:
    """Order minimising ``ic`` ("aic" or "bic") among fits from :func:`fit_orders`.

    Same criterion as ``statsmodels.tsa.ar_model.ar_select_order`` (which
    also holds back ``maxlag`` observations), computed from the AutoReg
    results directly: ``ar_select_order`` needs memory quadratic in the series
    length in statsmodels 0.15 (12 GB for 30 000 samples).
    """
    if ic not in ("aic", "bic"):
        raise ValueError(f"ic must be 'aic' or 'bic', got {ic!r}")
    values = [getattr(f, ic) for f in fits]
    return fits[int(np.argmin(values))].order


def ar_psd(coefs: np.ndarray, sigma2: float, freqs: np.ndarray, fs: float) -> np.ndarray:
    """One-sided PSD of an AR process (same scaling as ``scipy.signal.welch``).

    ``S(f) = 2 sigma2 / fs / |1 - sum_i a_i exp(-j 2 pi f i / fs)|^2``, computed
    with ``scipy.signal.freqz``.
    """
    from scipy import signal

    a = np.concatenate([[1.0], -np.asarray(coefs, dtype=float)])
    _, h = signal.freqz([1.0], a, worN=np.asarray(freqs, dtype=float), fs=fs)
    return 2.0 * sigma2 / fs * np.abs(h) ** 2


def simulate_ar(coefs: np.ndarray, sigma2: float, n: int, rng: np.random.Generator, const: float = 0.0, burn: int = 1000) -> np.ndarray:
    """Simulate an AR process with ``scipy.signal.lfilter`` (used in tests)."""
    from scipy import signal

    a = np.concatenate([[1.0], -np.asarray(coefs, dtype=float)])
    e = rng.normal(0.0, np.sqrt(sigma2), n + burn) + const
    return signal.lfilter([1.0], a, e)[burn:]
