"""The smallest 1-ms discriminator-output jitter a linear causal tracker can reach on a phase process.

A phase tracker's discriminator output at epoch k is, in the linear (small
error) model, ``e_k = theta_k - theta_hat_k + n_k``: the error of its
prediction ``theta_hat_k`` of the true phase, made from the past prompts,
plus the thermal phase noise ``n_k`` of the prompt, white with variance
``R = 1 / (2 C/N0 T)`` (:func:`scintrack.experiments.floors.phase_noise_variance`).
These numbers bound or attain ``var(e)``:

* **Prediction bound** (:func:`discriminator_bound`):
  ``sigma^2_pred + R`` with ``sigma^2_pred`` the one-step prediction error
  variance of the noise-free sampled phase (a predictor that saw the past
  phase without noise).  No tracker does better, since ``n_k`` is
  independent of everything before epoch k.  Under amplitude fading the
  prompt's phase noise is ``R / rho_k^2``; :func:`scenario_bound` also gives
  the bound with the window's mean of it (a bound for the same reason).
* **Wiener bound**: the innovation variance of the measured phase
  ``y_k = theta_k + n_k``, i.e. the same formula applied to the spectrum of
  ``y`` (:func:`white_increment_psd` adds ``n``).  It is the smallest
  ``var(e)`` of any linear causal tracker that sees only the prompts, and the
  Wiener (steady-state Kalman) predictor attains it.  The error of the best
  causal *filtered* estimate (prompts up to and including k) is then
  ``R (1 - R / sigma^2_innov)`` (:func:`filtering_error_variance`; the scalar
  Kalman update ``P+ = P- R / (P- + R)`` with ``P- + R = sigma^2_innov``).
* **Best third-order loop** (:func:`best_third_order_loop`): the package's
  third-order PLL loop filter (:func:`scintrack.trackers.blocks.pll_step`)
  run in the linear model over a grid of noise bandwidths; the bandwidth
  with the smallest discriminator jitter and that jitter.

Kolmogorov-Szegő formula (Brockwell & Davis, *Time Series: Theory and
Methods*, 2nd ed. 1991, Sec. 5.8, eq. 5.8.1, in physical units).  For a
stationary sequence sampled at ``fs`` with two-sided spectral density
``S_d(f)`` (rad^2/Hz; ``var = int_{-fs/2}^{fs/2} S_d df``), the one-step
prediction error variance from the infinite past is::

    sigma^2 = fs * exp( (1/fs) int_{-fs/2}^{fs/2} ln S_d(f) df )
            = fs * exp( (2/fs) int_0^{fs/2} ln S_d(f) df )      (S_d even)

(white noise of variance v: ``S_d = v / fs`` gives ``sigma^2 = v``).  A
one-sided density (``S_1 = 2 S_d`` for ``0 < f < fs/2``, the ISMR ``T f^-p``
convention and scipy's ``welch`` default) is halved first.  ``S_d`` is the
density of the *sampled* sequence: a continuous-time ``S(f)`` aliases,
``S_d(f) = sum_k S(f + k fs)`` (:func:`power_law_psd`).

Differencing.  The phase is not stationary (its spectrum grows without
bound towards 0 Hz) and is studied through its d-th differences: the
prediction error of ``theta_k`` from its past equals that of
``(Delta^d theta)_k`` from its past, and in the formula the factor
``|1 - exp(-j 2 pi f / fs)|^{2d} = (2 sin(pi f / fs))^{2d}`` of the
difference integrates to zero (``int ln(4 sin^2(pi nu)) dnu = 0`` over a
period), so the formula applied to the spectrum of the differences gives the
same number.  Differencing also keeps a Welch estimate (Hann window) from
filling the steep high-frequency part of a phase spectrum with leakage.

Estimates from a series.  :func:`increment_psd`: Welch (``scipy.signal.welch``,
Hann window, 50 % overlap, segment mean removed) of the d-th differences.
The mean of the log of a Welch estimate is biased by
``psi(nu/2) - ln(nu/2)`` (about ``-1/nu``; ``nu`` the equivalent degrees of
freedom of the average, Percival & Walden, *Spectral Analysis for Physical
Applications*, 1993, eq. 292b); :func:`increment_psd` removes it, so the
formula is not biased low by a few per cent.  :func:`ar_innovation_variance`
is the independent route that uses no spectrum: the innovation variance of a
Yule-Walker AR fit of the differences (Levinson-Durbin over every order at
once, ``statsmodels.tsa.stattools.levinson_durbin``), its order chosen by
AIC (``N ln sigma^2_k + 2 k``).  The package's OLS fits
(:func:`scintrack.models.ar.fit_orders`) give the same variances but take
tens of seconds per 60 000-sample series at the orders needed here.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ..errors import InputError
from ..trackers.blocks.loop_filter import pll_constants, pll_step
from .floors import phase_noise_variance

#: Noise bandwidths of the third-order loop sweep (Hz), the pre-declared 2 to 40 Hz in 1-Hz steps.
BANDWIDTHS_HZ = np.arange(2.0, 41.0, 1.0)
#: Welch segment length (samples; shorter in windows of fewer than 8192 epochs) and difference order of the estimates.
NPERSEG = 4096
DIFFERENCE = 1
#: Largest AR order of the spectrum-free route (at most a twentieth of the window in :func:`scenario_bound`).
AR_MAX_ORDER = 200
#: Noise realisations (trials) of the scenario loop sweep.
LOOP_TRIALS = 8


# --- the formula ------------------------------------------------------------------------


def kolmogorov_szego(freqs: np.ndarray, psd: np.ndarray, fs: float, *, sided: str = "two") -> float:
    """One-step prediction error variance ``fs exp((2/fs) int_0^{fs/2} ln S_d df)`` (module docstring).

    ``freqs``: increasing grid covering ``[0, fs/2]`` (trapezoidal rule);
    ``psd``: the density of the sampled sequence on it, two-sided
    (``sided="two"``) or one-sided (``"one"``: halved first).
    """
    f = np.asarray(freqs, dtype=float)
    s = np.asarray(psd, dtype=float)
    if sided not in ("one", "two"):
        raise InputError(f"sided must be 'one' or 'two' (got {sided!r})")
    if f.ndim != 1 or f.shape != s.shape or f.size < 3:
        raise InputError(f"freqs and psd must be 1-D arrays of the same length >= 3 (got {f.shape} and {s.shape})")
    if not (abs(f[0]) < 1e-9 * fs and abs(f[-1] - fs / 2) < 1e-9 * fs and np.all(np.diff(f) > 0)):
        raise InputError(f"freqs must increase from 0 to fs/2 = {fs / 2:g} Hz (got {f[0]:g} .. {f[-1]:g})")
    if not np.all(np.isfinite(s) & (s > 0)):
        raise InputError("psd must be finite and > 0 everywhere on [0, fs/2] (the log-integral needs it)")
    if sided == "one":
        s = s / 2.0
    return float(fs * np.exp(2.0 / fs * np.trapezoid(np.log(s), f)))


def power_law_psd(freqs: np.ndarray, strength: float, slope: float, fs: float, f_cut: float) -> np.ndarray:
    """Two-sided density of the phase with one-sided PSD ``T f^-p``, sampled at ``fs`` (aliased).

    ``S(f) = (T/2) (f^2 + f_cut^2)^(-p/2)`` (cut off below ``f_cut`` so that the
    variance is finite), plus its aliases ``(T/2) sum_{k != 0} |f + k fs|^-p =
    (T/2) fs^-p (zeta(p, 1 + f/fs) + zeta(p, 1 - f/fs))`` (Hurwitz zeta; the
    cut-off is negligible there, ``f_cut << fs``).  Needs ``p > 1``.
    """
    from scipy.special import zeta

    f = np.abs(np.asarray(freqs, dtype=float))
    if not (slope > 1.0 and strength > 0.0 and 0.0 < f_cut < fs / 2):
        raise InputError(f"power law needs T > 0, p > 1 and 0 < f_cut < fs/2 (got T={strength!r}, p={slope!r}, f_cut={f_cut!r})")
    nu = f / fs
    if np.any(nu > 0.5 + 1e-12):
        raise InputError("power_law_psd: freqs must lie in [-fs/2, fs/2]")
    main = (f**2 + f_cut**2) ** (-slope / 2.0)
    aliases = fs**-slope * (zeta(slope, 1.0 + nu) + zeta(slope, 1.0 - nu))
    return 0.5 * strength * (main + aliases)


def white_increment_psd(freqs: np.ndarray, variance: float, fs: float, difference: int = DIFFERENCE) -> np.ndarray:
    """Two-sided density of the d-th differences of white noise of ``variance``: ``(2 sin(pi f/fs))^(2d) variance / fs``."""
    f = np.asarray(freqs, dtype=float)
    return (2.0 * np.sin(np.pi * f / fs)) ** (2 * int(difference)) * float(variance) / fs


def filtering_error_variance(innovation_variance, thermal_variance):
    """``R (1 - R / sigma^2_innov)``: error variance of the best causal filtered phase (module docstring)."""
    r = np.asarray(thermal_variance, dtype=float)
    return r * (1.0 - r / np.asarray(innovation_variance, dtype=float))


def thermal_variance(cn0_dbhz: float, ts: float) -> float:
    """``R = 1 / (2 C/N0 T)`` [rad^2], the thermal phase noise of one prompt (the package's floors formula)."""
    return phase_noise_variance(cn0_dbhz, ts)


def discriminator_bound(prediction_variance, thermal: float):
    """``sqrt(sigma^2_pred + R)`` [rad]: no tracker's discriminator jitter is below it."""
    return np.sqrt(np.asarray(prediction_variance, dtype=float) + thermal)


# --- estimates from a series ------------------------------------------------------------


def _differenced(x: np.ndarray, difference: int, what: str) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or not np.all(np.isfinite(x)):
        raise InputError(f"{what}: the series must be 1-D and finite")
    if int(difference) != difference or difference < 0:
        raise InputError(f"{what}: difference must be an integer >= 0 (got {difference!r})")
    return np.diff(x, n=int(difference)) if difference else x


def welch_log_bias(n: int, nperseg: int) -> float:
    """``E[ln S_hat / S] = psi(nu/2) - ln(nu/2)`` of a Hann, 50 %-overlap Welch average of ``n`` samples.

    ``nu = 2 K / (1 + 2 sum_{j=1}^{K-1} (1 - j/K) rho_j^2)`` (Percival & Walden
    1993, eq. 292b), ``K`` segments, ``rho_j = sum_t h_t h_{t + j step} / sum_t h_t^2``
    the overlap of the window ``h`` with itself shifted by ``j`` steps (1/6 for
    Hann at 50 %).
    """
    from scipy.signal import get_window
    from scipy.special import digamma

    step = nperseg - nperseg // 2
    k = 1 + (n - nperseg) // step
    w = get_window("hann", nperseg)
    rho = np.array([np.sum(w[j * step :] * w[: nperseg - j * step]) for j in range(1, k) if j * step < nperseg]) / np.sum(w * w)
    j = np.arange(1, rho.size + 1)
    nu = 2.0 * k / (1.0 + 2.0 * np.sum((1.0 - j / k) * rho**2))
    return float(digamma(nu / 2.0) - np.log(nu / 2.0))


def increment_psd(x: np.ndarray, fs: float, *, nperseg: int = NPERSEG, difference: int = DIFFERENCE) -> tuple[np.ndarray, np.ndarray]:
    """``(f, S_d)``: two-sided Welch density of the ``difference``-th differences of ``x`` on ``[0, fs/2]``.

    Divided by ``exp(welch_log_bias)`` so that ``mean(ln S_d)`` is unbiased
    (scipy's one-sided output has its interior bins doubled; they are halved).
    """
    from scipy import signal

    d = _differenced(x, difference, "increment_psd")
    if d.size < 2 * nperseg:
        raise InputError(f"increment_psd: {d.size} samples are too few for Welch segments of {nperseg} (need >= {2 * nperseg})")
    f, s = signal.welch(d, fs=fs, window="hann", nperseg=nperseg, noverlap=nperseg // 2, detrend="constant")
    s = s.copy()
    s[1:-1] /= 2.0  # even nperseg: 0 and fs/2 are the only bins scipy does not double
    return f, s / np.exp(welch_log_bias(d.size, nperseg))


def ar_innovation_variance(x: np.ndarray, *, difference: int = DIFFERENCE, max_order: int = AR_MAX_ORDER) -> tuple[float, int]:
    """(innovation variance, order) of the Yule-Walker AR fit of the differences with the AIC order (module docstring)."""
    from statsmodels.tsa.stattools import acovf, levinson_durbin

    d = _differenced(x, difference, "ar_innovation_variance")
    if d.size < 10 * max_order:
        raise InputError(f"ar_innovation_variance: {d.size} samples are too few for AR orders up to {max_order}")
    acov = acovf(d, demean=True, fft=True, nlag=max_order)
    sigma = np.asarray(levinson_durbin(acov, nlags=max_order, isacov=True).sigma, dtype=float).copy()
    sigma[0] = acov[0]  # order 0: the variance (statsmodels leaves the slot at 0)
    aic = d.size * np.log(sigma) + 2.0 * np.arange(sigma.size)
    order = int(np.argmin(aic))
    return float(sigma[order]), order


# --- the best third-order loop ----------------------------------------------------------


class LoopSweep(NamedTuple):
    """Discriminator jitter of the linear third-order loop per bandwidth, and the best of them."""

    bandwidths_hz: np.ndarray
    jitter_rad: np.ndarray  # (bandwidth,): mean over trials of the windowed std
    best_bandwidth_hz: float
    best_jitter_rad: float


@njit(cache=True)
def linear_pll_errors(phase, noise, bandwidth_hz, ts):
    """Discriminator outputs ``e_k = phase_k - phase_hat_k + noise_k`` (trials, epochs) of the third-order loop.

    The loop starts on the first true phase with zero frequency and rate and
    steps with :func:`~scintrack.trackers.blocks.pll_step` after every epoch,
    as :func:`scintrack.trackers.pll.pll_kernel` does with the ATAN2 output.
    """
    k3, k2, k1 = pll_constants(bandwidth_hz, ts)
    n_tr, n = noise.shape
    out = np.empty((n_tr, n))
    for t in range(n_tr):
        est, v, w = phase[t, 0], 0.0, 0.0
        for k in range(n):
            e = phase[t, k] - est + noise[t, k]
            out[t, k] = e
            est, v, w = pll_step(est, v, w, e, k3, k2, k1, ts)
    return out


def windowed_jitter(e: np.ndarray, per_window: int | None, start: int) -> np.ndarray:
    """Per row: the mean, over the windows of ``per_window`` samples that start at or after ``start``,
    of the std in each window (the Susi tables' jitter, :func:`scintrack.experiments.runner.window_std`);
    ``per_window=None``: the std of ``e[..., start:]``."""
    from .runner import window_std

    if per_window is None:
        return e[..., int(start) :].std(axis=-1)
    std = window_std(e, per_window)
    first = -(-int(start) // per_window)
    if first >= std.shape[-1]:
        raise InputError(f"no jitter window of {per_window} samples starts at or after sample {start} (series of {e.shape[-1]})")
    return std[..., first:].mean(axis=-1)


def best_third_order_loop(phase: np.ndarray, cn0_dbhz: float, ts: float, noise: np.ndarray, *, amplitude: np.ndarray | None = None,
                          bandwidths_hz: np.ndarray = BANDWIDTHS_HZ, per_window: int | None = None, start: int = 0) -> LoopSweep:
    """The third-order loop's discriminator jitter on ``phase`` over ``bandwidths_hz``, and the smallest.

    ``phase``: true phase (epochs,) or (trials, epochs) [rad], at ``ts``;
    ``noise``: unit normal draws (trials, epochs), scaled by ``sqrt(R)`` with
    ``R = 1/(2 C/N0 T)`` and divided by ``amplitude`` when given (the prompt's
    phase noise under amplitude fading, ``R / rho^2``).  Every bandwidth sees
    the same draws.  Jitter: :func:`windowed_jitter` (one window from
    ``start`` to the end when ``per_window`` is None), then the mean over trials.
    """
    noise = np.asarray(noise, dtype=float)
    if noise.ndim != 2:
        raise InputError(f"noise must be (trials, epochs) unit normal draws (got shape {noise.shape})")
    theta = np.ascontiguousarray(np.broadcast_to(np.asarray(phase, dtype=float), noise.shape))
    sigma = np.sqrt(thermal_variance(cn0_dbhz, ts))
    if amplitude is not None:
        rho = np.asarray(amplitude, dtype=float)
        if not np.all(np.isfinite(rho) & (rho > 0)):
            raise InputError("amplitude must be finite and > 0 (the noise is divided by it)")
        sigma = sigma / rho
    scaled = np.ascontiguousarray(noise * sigma)
    per = int(per_window) if per_window else None
    bws = np.asarray(bandwidths_hz, dtype=float)
    jitter = np.array([windowed_jitter(linear_pll_errors(theta, scaled, float(b), float(ts)), per, start).mean() for b in bws])
    best = int(np.argmin(jitter))
    return LoopSweep(bws, jitter, float(bws[best]), float(jitter[best]))


# --- one scenario -----------------------------------------------------------------------

#: Noise models of the loop sweep: the nominal prompt noise R, or R / rho^2 with the trace's amplitude.
NOISE_MODELS = ("nominal", "fading")


def scenario_bound(*, name: str, phase: np.ndarray, amplitude: np.ndarray, clock: np.ndarray, cn0_dbhz: float, ts: float,
                   per_window: int, steady_start: int, noise: np.ndarray):
    """Bounds and the best third-order loop of one scenario, per jitter window and summarised (xarray Dataset).

    ``phase``, ``amplitude``: the scintillation (epochs,) every trial sees;
    ``clock``: the receiver oscillator's phase (trials, epochs); the tracked
    phase of trial i is ``phase + clock[i]`` (the deterministic Doppler
    polynomial is left out: a third-order loop and the infinite-past predictor
    follow a quadratic phase without error).  The spectrum and AR estimates
    use trial 0; ``noise`` (trials, epochs) are the unit normal draws of the
    loop sweep, whose row 0 also makes the measured phase of the AR Wiener
    route.  Summaries (``*_rad``): the mean, over the windows that start at or
    after ``steady_start``, of each window's value, as the Susi tables average
    their windowed jitter.
    """
    import xarray as xr

    fs = 1.0 / ts
    phase = np.asarray(phase, dtype=float)
    clock = np.atleast_2d(np.asarray(clock, dtype=float))
    rho = np.asarray(amplitude, dtype=float)
    n = phase.size
    if clock.shape[1] != n or rho.shape != (n,) or noise.shape != clock.shape:
        raise InputError(f"scenario {name}: phase {phase.shape}, amplitude {rho.shape}, clock {clock.shape} and noise {noise.shape} disagree")
    n_win = n // per_window
    if n_win < 1:
        raise InputError(f"scenario {name}: {n} epochs hold no jitter window of {per_window}")
    if per_window < 256:
        raise InputError(f"scenario {name}: jitter windows of {per_window} epochs are too short for a spectrum estimate (need >= 256)")
    nperseg = min(NPERSEG, 1 << int(np.log2(per_window // 2)))  # at least 2 Welch segments per window (short test configs)
    max_order = min(AR_MAX_ORDER, per_window // 20)
    r = thermal_variance(cn0_dbhz, ts)
    x = phase + clock[0]
    y = x + np.sqrt(r) * noise[0]
    cols = {k: np.empty(n_win) for k in ("pred_psd", "pred_ar", "innov_psd", "innov_ar", "r_fading")}
    orders = {k: np.empty(n_win, dtype=np.int64) for k in ("pred_ar", "innov_ar")}
    for w in range(n_win):
        sl = slice(w * per_window, (w + 1) * per_window)
        f, s = increment_psd(x[sl], fs, nperseg=nperseg)
        cols["pred_psd"][w] = kolmogorov_szego(f, s, fs)
        cols["innov_psd"][w] = kolmogorov_szego(f, s + white_increment_psd(f, r, fs), fs)
        cols["pred_ar"][w], orders["pred_ar"][w] = ar_innovation_variance(x[sl], max_order=max_order)
        cols["innov_ar"][w], orders["innov_ar"][w] = ar_innovation_variance(y[sl], max_order=max_order)
        cols["r_fading"][w] = np.mean(r / rho[sl] ** 2)
    steady = np.arange(n_win) * per_window >= steady_start
    if not steady.any():
        raise InputError(f"scenario {name}: no {per_window * ts:g}-s window starts after the steady-state start ({steady_start * ts:g} s)")

    def summary(values):
        return float(np.mean(np.asarray(values)[steady]))

    sweeps = [best_third_order_loop(phase[None, :] + clock, cn0_dbhz, ts, noise, amplitude=None if model == "nominal" else rho,
                                    per_window=per_window, start=steady_start) for model in NOISE_MODELS]
    window = (np.arange(n_win) + 0.5) * per_window * ts
    rad = {"units": "rad"}
    var = {"units": "rad2"}
    ds = xr.Dataset(
        {
            "prediction_var_psd": ("window", cols["pred_psd"], {**var, "long_name": "one-step prediction error variance of the noise-free phase (Kolmogorov-Szego, Welch)"}),
            "prediction_var_ar": ("window", cols["pred_ar"], {**var, "long_name": "the same from a Yule-Walker AR fit (AIC order)"}),
            "prediction_ar_order": ("window", orders["pred_ar"]),
            "innovation_var_psd": ("window", cols["innov_psd"], {**var, "long_name": "innovation variance of the measured phase (Wiener bound, Kolmogorov-Szego)"}),
            "innovation_var_ar": ("window", cols["innov_ar"], {**var, "long_name": "the same from a Yule-Walker AR fit of one noisy realisation"}),
            "innovation_ar_order": ("window", orders["innov_ar"]),
            "thermal_var_fading": ("window", cols["r_fading"], {**var, "long_name": "mean of R / rho^2 over the window"}),
            "steady": ("window", steady),
            "thermal_var": ((), r, {**var, "long_name": "R = 1/(2 C/N0 T)"}),
            "bound_rad": ((), summary(discriminator_bound(cols["pred_psd"], r)), {**rad, "long_name": "sqrt(sigma^2_pred + R)"}),
            "bound_fading_rad": ((), summary(np.sqrt(cols["pred_psd"] + cols["r_fading"])), {**rad, "long_name": "sqrt(sigma^2_pred + mean R/rho^2)"}),
            "wiener_bound_rad": ((), summary(np.sqrt(cols["innov_psd"])), {**rad, "long_name": "sqrt(innovation variance), spectrum route"}),
            "wiener_bound_ar_rad": ((), summary(np.sqrt(cols["innov_ar"])), {**rad, "long_name": "sqrt(innovation variance), AR route"}),
            "tracking_bound_rad": ((), summary(np.sqrt(filtering_error_variance(cols["innov_psd"], r))),
                                   {**rad, "long_name": "error std of the best causal filtered phase, sqrt(R (1 - R/sigma^2_innov))"}),
            "pll_jitter_rad": (("noise_model", "bandwidth_hz"), np.stack([sw.jitter_rad for sw in sweeps]),
                               {**rad, "long_name": "discriminator jitter of the linear third-order loop"}),
            "best_bandwidth_hz": ("noise_model", [sw.best_bandwidth_hz for sw in sweeps], {"units": "Hz"}),
            "best_pll_jitter_rad": ("noise_model", [sw.best_jitter_rad for sw in sweeps], rad),
        },
        coords={"window": ("window", window, {"units": "s", "long_name": "window centre"}), "noise_model": list(NOISE_MODELS),
                "bandwidth_hz": ("bandwidth_hz", BANDWIDTHS_HZ, {"units": "Hz"})},
        attrs={"scenario": name, "cn0_dbhz": float(cn0_dbhz), "ts": float(ts), "window_s": per_window * ts, "steady_state_start_s": steady_start * ts,
               "loop_trials": int(noise.shape[0]), "nperseg": nperseg, "difference": DIFFERENCE, "ar_max_order": max_order},
    )
    return ds
