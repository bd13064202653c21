"""On-line estimator of the phase-scintillation PSD strength T and slope p.

Susi, Andreotti & Aquino 2014 model the scintillation phase PSD by the power
law of their eq. (2), ``S(f) = T f^-p`` (``f >> f0``), with ``T`` the
strength at 1 Hz and ``p`` the slope, and feed T and p to the SAKF PLL's
process noise (eqs. 7-8): "p and T are computed by detrending the carrier
phase obtained from the PLL and by evaluating respectively the slope and the
strength of the carrier FFT computed at 1 Hz ... over a sliding window of
3000 samples" (Sec. 3; 3 s at 1 ms).  The chapter gives no more detail
(reference notes §4), so the procedure here is the standard ISMR one, an
assumption: detrend with the 0.1-Hz 6th-order Butterworth high-pass
(:func:`scintrack.estimators.sigma_phi.detrend_sos`), Hann-windowed
periodogram of the last N samples, least-squares line of log10 P on log10 f
over a band, ``p = -slope`` and ``T`` = the line at 1 Hz.

Per-sample numba blocks (the tracker kernel calls them every epoch):

* :func:`sos_step`: one sample through second-order sections in transposed
  direct form II, exactly ``scipy.signal.sosfilt``'s arithmetic;
* :func:`sdft_push`: sliding DFT of the bins the fit needs,
  ``S_k <- e^{j 2 pi k/N} (S_k + x_new - x_old)``, with an exact re-computation
  from the ring buffer once per lap so rounding cannot drift.  This
  recursion keeps ``S_k`` equal to the ordinary DFT ``X_k = sum_m x_m
  e^{-j 2 pi k m/N}`` of the window with ``m = 0`` its oldest sample (the
  ``m = -1`` term it adds and the ``m = N - 1`` term it lacks carry the same
  twiddle ``e^{j 2 pi k/N}``), so no phase conversion is needed;
* :func:`power_law_fit`: Hann-windowed one-sided periodogram from the bins and
  the log-log least-squares fit.

:func:`spectrum_setup` builds the constants (:class:`SpectrumSetup`).  The
numpy batch :func:`estimate_power_law` (windows through ``np.fft.rfft``) and
the causal :func:`online_power_law` (the tracker's view) both end in
:func:`power_law_fit`, so the periodogram and fit formulas exist once.

Periodogram.  With the periodic Hann window ``w[m] = 0.5 - 0.5 cos(2 pi m/N)``
the windowed DFT is ``X_hann[k] = 0.5 X[k] - 0.25 X[k-1] - 0.25 X[k+1]``, and
the one-sided PSD estimate is ``P_k = 2 ts |X_hann[k]|^2 / sum(w^2)`` with
``sum(w^2) = 3N/8`` (white noise of variance s^2 gives ``2 ts s^2``; the
one-sided PSD integrates to the variance over 0 .. 1/(2 ts)).  Input phase in
rad gives T in rad^2/Hz at 1 Hz (one-sided).

Fit.  ``log10 P_k`` on ``log10 f_k``, ``f_k = k / (N ts)``, for
``k_lo <= k <= k_hi``; ``P_k <= 0`` is floored at 1e-30.  A periodogram
ordinate of a Gaussian process is ``S(f_k)`` times an exponential variable
(chi-square with 2 degrees of freedom over 2) whose mean log10 is ``-gamma /
ln 10 = -0.2507`` (gamma = Euler's constant), so the fitted line lies 0.2507
below log10 S: ``T = 10^(intercept + gamma / ln 10)`` removes that bias; the
slope is unaffected.

Band.  Defaults ``f_lo_hz = 0.5``, ``f_hi_hz = 5.0`` for the 3-s window (bins
k = 2 .. 15, 0.67 .. 5 Hz at 1/3-Hz resolution): bins below ~0.5 Hz are shaped
by the 0.1-Hz high-pass (its start-up and its roll-off through the Hann
main lobe, two bins wide) and by the window's leakage of the steep low
frequencies; above ~5 Hz the phase a tracker outputs is dominated by thermal
noise and by its loop filtering (loop bandwidths of 10-15 Hz and below), not
by the scintillation power law.

Known bias of that band (measured, tests/test_scint_estimators.py, and
computed from the exact expected Hann periodogram of ``T f^-p`` behind the
0.1-Hz high-pass): the Hann main lobe (+-2 bins = +-0.67 Hz) averages the
convex spectrum, so the lowest fitted bins read high (about ``1 + p(p+1) /
(6 k^2)``: x1.5 at k = 2 for p = 3).  At 0.5 .. 5 Hz this biases ``p`` up by
0.13 / 0.20 / 0.29 and ``T`` by +18 / +29 / +45 % for p = 2 / 2.5 / 3; a band
starting at 1.5 Hz cuts it to <= 0.07 and <= 11 % but doubles the per-window
scatter (std of p over single 3-s windows 0.66 -> 1.3 with f_hi = 5 Hz), so
its per-window error is larger.  A 1.5 .. 15 Hz band (noise-free phase only)
recovers p within 0.03 and T within ~6 %.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np
from numba import njit

#: Euler's gamma / ln 10: minus the mean log10 of a chi-square(2)/2 periodogram ordinate
LOG10_PERIODOGRAM_BIAS = 0.5772156649015329 / math.log(10.0)
#: floor of a periodogram ordinate before its log10
P_FLOOR = 1e-30


class SpectrumSetup(NamedTuple):
    """Constants of the sliding spectrum (numba-compatible: arrays and scalars only).

    ``k``: the stored bins k_lo-1 .. k_hi+1 (the Hann window needs each fitted
    bin's neighbours); ``tw_re``/``tw_im``: their twiddles ``exp(+j 2 pi k/N)``;
    ``log_f``: log10 of the fitted bins' frequencies ``k / (N ts)`` for
    k_lo .. k_hi (``k[1:-1]``); ``dft_re``/``dft_im``: ``cos``/``sin`` of
    ``2 pi m / N``, m = 0 .. N-1, for the exact once-per-lap re-computation.
    """

    n: int
    ts: float
    k: np.ndarray
    tw_re: np.ndarray
    tw_im: np.ndarray
    log_f: np.ndarray
    dft_re: np.ndarray
    dft_im: np.ndarray


@functools.lru_cache(maxsize=16)
def spectrum_setup(n_window: int, ts: float, f_lo_hz: float, f_hi_hz: float) -> SpectrumSetup:
    """Constants for a window of ``n_window`` samples at ``ts`` fitted over [f_lo_hz, f_hi_hz].

    ``k_lo = ceil(f_lo N ts)``, ``k_hi = floor(f_hi N ts)`` (to 1e-9 of a bin,
    so that a band edge on a bin keeps it; cached: callers must not write into the arrays); requires ``1 <= k_lo < k_hi <=
    N/2 - 1`` (two fitted bins, each with both neighbours below Nyquist).
    """
    n = int(n_window)
    if n < 4:
        raise ValueError(f"n_window = {n_window} is too short for a spectrum fit (need >= 4 samples)")
    k_lo = math.ceil(f_lo_hz * n * ts - 1e-9)
    k_hi = math.floor(f_hi_hz * n * ts + 1e-9)
    if k_lo < 1:
        raise ValueError(f"f_lo_hz = {f_lo_hz:g} Hz is below the first bin 1/(n_window ts) = {1.0 / (n * ts):g} Hz (n_window = {n}, ts = {ts:g} s)")
    if k_hi > n // 2 - 1:
        raise ValueError(f"f_hi_hz = {f_hi_hz:g} Hz is above the last usable bin {(n // 2 - 1) / (n * ts):g} Hz (n_window = {n}, ts = {ts:g} s)")
    if k_hi <= k_lo:
        raise ValueError(f"f_lo_hz = {f_lo_hz:g} .. f_hi_hz = {f_hi_hz:g} Hz holds fewer than two bins of 1/(n_window ts) = {1.0 / (n * ts):g} Hz (n_window = {n}, ts = {ts:g} s)")
    k = np.arange(k_lo - 1, k_hi + 2, dtype=np.int64)
    ang = 2.0 * np.pi * k / n
    m_ang = 2.0 * np.pi * np.arange(n) / n
    return SpectrumSetup(
        n=n, ts=float(ts), k=k, tw_re=np.cos(ang), tw_im=np.sin(ang), log_f=np.log10(k[1:-1] / (n * ts)), dft_re=np.cos(m_ang), dft_im=np.sin(m_ang)
    )


@njit(cache=True)
def sos_step(sos, zi, x):
    """One sample through the sections ``sos`` (rows [b0, b1, b2, 1, a1, a2]); ``zi`` (n_sections, 2) updated in place.

    Transposed direct form II, the arithmetic of ``scipy.signal.sosfilt``:
    ``y = b0 x + z0``, ``z0 <- b1 x - a1 y + z1``, ``z1 <- b2 x - a2 y``.
    """
    for s in range(sos.shape[0]):
        y = sos[s, 0] * x + zi[s, 0]
        zi[s, 0] = sos[s, 1] * x - sos[s, 4] * y + zi[s, 1]
        zi[s, 1] = sos[s, 2] * x - sos[s, 5] * y
        x = y
    return x


@njit(cache=True)
def _exact_bins(setup, buf, s_re, s_im):
    """S_k = sum_m buf[m] e^{-j 2 pi k m/N}: the DFT of a buffer whose oldest sample is at m = 0."""
    n = setup.n
    for j in range(setup.k.size):
        k = setup.k[j]
        re = 0.0
        im = 0.0
        for m in range(n):
            q = (k * m) % n
            re += buf[m] * setup.dft_re[q]
            im -= buf[m] * setup.dft_im[q]
        s_re[j] = re
        s_im[j] = im


@njit(cache=True)
def sdft_push(setup, buf, pos, count, s_re, s_im, x):
    """Push ``x`` into the ring buffer ``buf`` (length N) and update the bins; returns (pos, count).

    ``S_k <- e^{j 2 pi k/N} (S_k + x - x_old)``; when ``pos`` wraps to 0 the
    buffer is in time order (oldest at 0) and every ``S_k`` is recomputed
    exactly from it.  ``S_k`` is the DFT of the last N samples, oldest first
    (zeros before the first N pushes).
    """
    d = x - buf[pos]
    buf[pos] = x
    pos = (pos + 1) % buf.size
    count = min(count + 1, buf.size)
    if pos == 0:
        _exact_bins(setup, buf, s_re, s_im)
    else:
        for j in range(s_re.size):
            a = s_re[j] + d
            b = s_im[j]
            s_re[j] = setup.tw_re[j] * a - setup.tw_im[j] * b
            s_im[j] = setup.tw_re[j] * b + setup.tw_im[j] * a
    return pos, count


@njit(cache=True)
def power_law_fit(setup, s_re, s_im):
    """(T, p) of ``S(f) = T f^-p`` fitted to the Hann periodogram of the stored bins (module docstring)."""
    nf = setup.log_f.size
    scale = 2.0 * setup.ts / (0.375 * setup.n)
    x_mean = 0.0
    for j in range(nf):
        x_mean += setup.log_f[j]
    x_mean /= nf
    y_mean = 0.0
    sxy = 0.0
    sxx = 0.0
    for j in range(nf):
        hr = 0.5 * s_re[j + 1] - 0.25 * (s_re[j] + s_re[j + 2])
        hi = 0.5 * s_im[j + 1] - 0.25 * (s_im[j] + s_im[j + 2])
        y = math.log10(max(scale * (hr * hr + hi * hi), P_FLOOR))
        dx = setup.log_f[j] - x_mean
        y_mean += y
        sxy += dx * y
        sxx += dx * dx
    y_mean /= nf
    slope = sxy / sxx
    intercept = y_mean - slope * x_mean
    return 10.0 ** (intercept + LOG10_PERIODOGRAM_BIAS), -slope


@njit(cache=True)
def _fit_spectra(setup, spectra, t_out, p_out):
    """(T, p) of each row of ``spectra`` (rows of ``numpy.fft.rfft`` output): the stored bins ``setup.k`` read in place."""
    nk = setup.k.size
    s_re = np.empty(nk)
    s_im = np.empty(nk)
    for r in range(spectra.shape[0]):
        for j in range(nk):
            v = spectra[r, setup.k[j]]
            s_re[j] = v.real
            s_im[j] = v.imag
        t_out[r], p_out[r] = power_law_fit(setup, s_re, s_im)


def estimate_power_law(
    phi: np.ndarray, ts: float, window_s: float = 3.0, f_lo_hz: float = 0.5, f_hi_hz: float = 5.0, step_s: float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(times, T, p) over windows of an (already detrended) phase, 1-D or (..., time).

    Windows of ``N = round(window_s / ts)`` samples start every
    ``round(step_s / ts)`` samples (``step_s=None``: every N, non-overlapping)
    from sample 0; ``times`` are the times of their *last* samples (sample n
    at ``n ts``), the epoch at which :func:`online_power_law` holds the same
    estimate.  Bins come from ``np.fft.rfft`` of each window (already in the
    SDFT's convention) and go through :func:`power_law_fit`.
    """
    phi = np.asarray(phi, dtype=float)
    n_win = int(round(window_s / ts))
    step = n_win if step_s is None else int(round(step_s / ts))
    if step < 1:
        raise ValueError(f"step_s = {step_s} s is shorter than one sample (ts = {ts:g} s)")
    setup = spectrum_setup(n_win, ts, f_lo_hz, f_hi_hz)
    lead, n = phi.shape[:-1], phi.shape[-1]
    rows = phi.reshape(-1, n)
    starts = np.arange(0, n - n_win + 1, step) if n >= n_win else np.zeros(0, dtype=int)
    t_out = np.empty((rows.shape[0], starts.size))
    p_out = np.empty((rows.shape[0], starts.size))
    chunk = max(1, 2_000_000 // n_win)  # windows per rfft call (bounds the memory)
    if starts.size == 1 and n == n_win:  # one window per row (the SAKF's refresh): one rfft over the rows, same bins
        _fit_spectra(setup, np.fft.rfft(rows, axis=-1), t_out[:, 0], p_out[:, 0])
    else:
        for r in range(rows.shape[0]):
            for c in range(0, starts.size, chunk):
                sel = starts[c : c + chunk]
                _fit_spectra(setup, np.fft.rfft(rows[r, sel[:, None] + np.arange(n_win)], axis=-1), t_out[r, c : c + sel.size], p_out[r, c : c + sel.size])
    times = (starts + n_win - 1) * ts
    return times, t_out.reshape(*lead, starts.size), p_out.reshape(*lead, starts.size)


@njit(cache=True)
def _online_loop(sos, setup, theta, hop, t_out, p_out):
    n_sec = sos.shape[0]
    nk = setup.k.size
    for i in range(theta.shape[0]):
        zi = np.zeros((n_sec, 2))
        buf = np.zeros(setup.n)
        s_re = np.zeros(nk)
        s_im = np.zeros(nk)
        pos = 0
        count = 0
        t_val = np.nan
        p_val = np.nan
        for e in range(theta.shape[1]):
            y = sos_step(sos, zi, theta[i, e])
            pos, count = sdft_push(setup, buf, pos, count, s_re, s_im, y)
            if count == setup.n and (e - (setup.n - 1)) % hop == 0:
                t_val, p_val = power_law_fit(setup, s_re, s_im)
            t_out[i, e] = t_val
            p_out[i, e] = p_val


def online_power_law(
    theta: np.ndarray, ts: float, window_s: float = 3.0, f_lo_hz: float = 0.5, f_hi_hz: float = 5.0, cutoff_hz: float = 0.1, hop: int = 1
) -> tuple[np.ndarray, np.ndarray]:
    """(T, p) per sample as a tracker computes them: causal high-pass -> SDFT -> fit, 1-D or (trials, time).

    ``theta`` (rad) goes sample by sample through :func:`sos_step` with the
    0.1-Hz high-pass (:func:`~scintrack.estimators.sigma_phi.detrend_sos`,
    zero initial state), :func:`sdft_push` and, at the first full window and
    every ``hop`` samples after it, :func:`power_law_fit`.  Values are NaN
    until the window is full and held between fits.
    """
    from .sigma_phi import detrend_sos

    theta = np.asarray(theta, dtype=float)
    if hop < 1:
        raise ValueError(f"hop = {hop} must be >= 1 sample")
    setup = spectrum_setup(int(round(window_s / ts)), ts, f_lo_hz, f_hi_hz)
    rows = np.ascontiguousarray(theta.reshape(-1, theta.shape[-1]))
    t_out = np.empty(rows.shape)
    p_out = np.empty(rows.shape)
    _online_loop(np.ascontiguousarray(detrend_sos(ts, cutoff_hz)), setup, rows, int(hop), t_out, p_out)
    return t_out.reshape(theta.shape), p_out.reshape(theta.shape)
