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

Types: :class:`ArModel` is the package's one AR type (fits, look-up-table
points, trace fits); :class:`ScintillationAR` pairs a phase and an amplitude
model as the AR-based trackers use them (eqs. 9-10).  :func:`simulate_ar` is
the one AR simulator (``scipy.signal.lfilter``), used by the AR-world
scenarios and the tests.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TRENDS = {"amplitude": "c", "phase": "n"}


@dataclass(frozen=True)
class ArModel:
    """One AR model: ``x_k = sum coefs[i] x_{k-1-i} + const + e_k``, ``e_k ~ N(0, sigma2)``.

    The one AR type of the package: fits (:func:`fit_ar`, with their AIC/BIC),
    look-up-table points (:func:`scintrack.models.lut.lookup`), trace fits and
    the trackers' models (in pairs, :class:`ScintillationAR`) all use it.
    """

    coefs: np.ndarray
    const: float = 0.0
    sigma2: float = 0.0
    aic: float = float("nan")
    bic: float = float("nan")

    @property
    def order(self) -> int:
        return int(np.size(self.coefs))

    @property
    def mean(self) -> float:
        """Process mean ``kappa / (1 - sum gamma_i)`` (nan for a unit root)."""
        denom = 1.0 - float(np.sum(self.coefs))
        return self.const / denom if abs(denom) > 1e-12 else float("nan")

    def simulate(self, n: int, rng: np.random.Generator, burn: int = 1000, start: float | None = None) -> np.ndarray:
        """``n`` samples of the process (:func:`simulate_ar`)."""
        return simulate_ar(self.coefs, self.sigma2, n, rng, const=self.const, burn=burn, start=start)


@dataclass(frozen=True)
class ScintillationAR:
    """The scintillation model of the AR-based trackers (Vila-Valls 2018, eqs. 9-10).

    ``phase``: AR(p) of theta_s without constant (coefficients beta_i,
    sigma_eta_theta^2); ``amplitude``: AR(q) of rho_s with constant kappa
    (gamma_i, sigma_eta_rho^2).  ``s4``/``tau0``: the point the models belong
    to (look-up-table grid point, trace fit), ``label``: where they come from.
    """

    phase: ArModel
    amplitude: ArModel
    s4: float = 0.0
    tau0: float = float("nan")
    label: str = ""

    @staticmethod
    def no_scintillation() -> ScintillationAR:
        """SSM #1 as in Case I: gamma_1 = 1, everything else 0."""
        return ScintillationAR(phase=ArModel(np.zeros(1)), amplitude=ArModel(np.array([1.0])), s4=0.0, label="none")

    @staticmethod
    def from_coefs(beta, gamma, kappa: float, sigma2_theta: float, sigma2_rho: float, s4: float = 0.0, tau0: float = float("nan"), label: str = "") -> ScintillationAR:
        """Shorthand: phase AR(beta, sigma2_theta), amplitude AR(gamma, kappa, sigma2_rho)."""
        return ScintillationAR(
            phase=ArModel(np.asarray(beta, dtype=float), 0.0, float(sigma2_theta)),
            amplitude=ArModel(np.asarray(gamma, dtype=float), float(kappa), float(sigma2_rho)),
            s4=float(s4), tau0=float(tau0), label=label,
        )

    @property
    def rho_mean(self) -> float:
        """Mean amplitude, the trackers' initial rho_s (1 when the amplitude AR has a unit root)."""
        denom = 1.0 - float(np.sum(self.amplitude.coefs))
        return self.amplitude.const / denom if abs(denom) > 1e-9 else 1.0

    def simulate(self, n: int, rng: np.random.Generator, burn: int = 2000) -> tuple[np.ndarray, np.ndarray]:
        """(theta_s, rho_s) drawn from the models themselves, phase first, one generator.

        The amplitude filter starts from ``lfilter_zi * rho_mean`` (as the
        original isolating experiment did; that is the steady state of an input
        ``rho_mean``, not ``kappa``, so the output starts at ``rho_mean / (1 -
        sum gamma)``); the ``burn`` samples remove that transient.  Kept as is:
        the results stay bit-identical.
        """
        theta = self.phase.simulate(n, rng, burn=burn)
        rho = self.amplitude.simulate(n, rng, burn=burn, start=self.rho_mean)
        return theta, rho


def _check_series(x: np.ndarray, order: int) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise ValueError("AR fitting expects a 1-D series")
    if not np.all(np.isfinite(x)):
        raise ValueError("AR fitting: the series contains NaN or inf")
    if x.size < 10 * max(order, 1):
        raise ValueError(f"AR fitting: {x.size} samples are too few for order {order}")
    return x


def fit_ar(x: np.ndarray, order: int, trend: str, hold_back: int | None = None) -> ArModel:
    """Fit AR(``order``) by conditional ML (OLS): statsmodels ``AutoReg(x, order, trend, hold_back).fit()``.

    ``hold_back`` (>= order; default ``order``) drops that many initial
    observations, so that fits of different orders share one estimation
    sample and their AIC/BIC compare.  Computed by :func:`_autoreg_fits`.
    """
    return _autoreg_fits(x, [order], trend, order if hold_back is None else hold_back)[0]


def _autoreg_fits(x: np.ndarray, orders: list[int], trend: str, hold_back: int) -> list[ArModel]:
    """AutoReg's fit of each order in ``orders`` on the sample ``x[hold_back:]``, from one design matrix.

    ``AutoReg(x, lags=order, trend=trend, hold_back=hold_back).fit()`` is, for
    ``trend`` "n" or "c" and no exog or seasonality: the regressors
    ``[1, x_{k-1}, ..., x_{k-order}]`` (the constant only for "c") from
    ``statsmodels.tsa.tsatools.lagmat``; the parameters from
    ``statsmodels.regression.linear_model.OLS(...).fit()`` (its pseudo-inverse);
    ``sigma2 = SSR / nobs`` of the in-sample residuals; the log-likelihood
    ``-(nobs/2) (log 2 pi + log(SSR/nobs) + 1)``; AIC and BIC from
    ``statsmodels.tools.eval_measures`` with ``df_model + 1`` parameters.  Here
    those same statsmodels calls run on one lag matrix per series (the lags of
    order o are the first o of its columns), and the model set-up AutoReg
    repeats per order is skipped: a date index and a frame of deterministic
    terms, and the test for an implicit constant (for "n", three SVDs of the
    design per fit; OLS is told whether a constant is present instead).  The
    results are AutoReg's bit for bit (``tests/test_ar.py`` compares
    parameters, sigma2, AIC and BIC as uint64 against AutoReg on many series);
    the eight fits of a 30 000-sample phase series take ~2.4x less time and of
    an amplitude series ~4x less (``docs/performance.md``).
    """
    from statsmodels.regression.linear_model import OLS  # imported here: heavy, and the AR types are used without it
    from statsmodels.tools import eval_measures
    from statsmodels.tsa.tsatools import lagmat

    if trend not in ("c", "n"):
        raise ValueError(f"trend must be 'c' or 'n', got {trend!r}")
    if min(orders) < 1:
        raise ValueError("AR order must be >= 1")
    if hold_back < max(orders):
        raise ValueError(f"hold_back ({hold_back}) must be >= the largest order ({max(orders)})")
    x = _check_series(x, hold_back)
    lags, leads = lagmat(x, max(orders), original="sep")
    y, lags, observed = leads[hold_back:], lags[hold_back:], x[hold_back:]
    nobs = y.shape[0]
    fits = []
    for order in orders:
        # contiguous, as AutoReg's own design (the products below then take the same BLAS path)
        design = np.c_[np.ones((nobs, 1)), lags[:, :order]] if trend == "c" else np.ascontiguousarray(lags[:, :order])
        params = np.asarray(OLS(y, design, hasconst=trend == "c").fit().params, dtype=float)
        resid = observed - design @ params  # AutoReg's sigma2: endog - fittedvalues
        sigma2 = 1.0 / nobs * np.sum(resid**2, axis=0)
        resid_llf = y.squeeze() - (design @ params[:, None]).squeeze()  # AutoReg's loglike: its own residual form
        ssr = resid_llf @ resid_llf
        llf = -(nobs / 2) * (np.log(2 * np.pi) + np.log(ssr / nobs) + 1)
        k = design.shape[1] + 1  # df_model + 1
        const, coefs = (float(params[0]), params[1:]) if trend == "c" else (0.0, params)
        fits.append(ArModel(coefs=coefs.copy(), const=const, sigma2=float(sigma2), aic=float(eval_measures.aic(llf, nobs, k)),
                            bic=float(eval_measures.bic(llf, nobs, k))))
    return fits


def pacf_with_bound(x: np.ndarray, nlags: int, alpha: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """Sample PACF at lags 0..nlags and the half-width of its (1-alpha) band around 0.

    Both come from ``statsmodels.tsa.stattools.pacf(method="ols", alpha=...)``;
    the band half-width is the distance from the estimate to its confidence
    limit, ``z_{1-alpha/2}/sqrt(N)``.
    """
    from statsmodels.tsa.stattools import pacf

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


def fit_orders(x: np.ndarray, max_order: int, trend: str) -> list[ArModel]:
    """AR(1..max_order) fitted on one common sample (``hold_back=max_order``), as :func:`fit_ar` each."""
    return _autoreg_fits(x, list(range(1, max_order + 1)), trend, max_order)


def ic_order(fits: list[ArModel], ic: str) -> int:
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


def simulate_ar(
    coefs: np.ndarray, sigma2: float, n: int, rng: np.random.Generator, const: float = 0.0, burn: int = 1000, start: float | None = None
) -> np.ndarray:
    """Simulate an AR process with ``scipy.signal.lfilter`` (the package's one AR simulator).

    ``e_k ~ N(0, sigma2) + const`` filtered by ``1 / (1 - sum a_i z^-i)``;
    ``burn`` samples are generated and dropped.  ``start``: the filter starts
    from ``lfilter_zi * start`` instead of at rest, i.e. in the steady state
    of a constant *input* ``start`` (output ``start / (1 - sum a_i)``).
    """
    from scipy import signal

    a = np.concatenate([[1.0], -np.asarray(coefs, dtype=float)])
    e = rng.normal(0.0, np.sqrt(sigma2), n + burn) + const
    if start is None:
        return signal.lfilter([1.0], a, e)[burn:]
    return signal.lfilter([1.0], a, e, zi=signal.lfilter_zi([1.0], a) * start)[0][burn:]
