"""The phase scintillation index sigma_phi (Phi60, Phi3) of a carrier phase in rad.

sigma_phi is the standard deviation of the *detrended* carrier phase over a
window (Susi, Andreotti & Aquino 2014, Sec. 2; reference notes §3.4): the
phase is high-passed by a 6th-order Butterworth at 0.1 Hz (the ISM receivers'
detrending) and its std is taken per window.

* :func:`detrend_sos`: the SOS array of that high-pass (shared by the zero-phase
  off-line detrending and by every causal on-line filter, e.g. the tracker's
  per-sample :func:`scintrack.estimators.power_law.sos_step`);
* :func:`detrend_phase`: zero-phase (``sosfiltfilt``) detrending, the off-line
  truth; :func:`window_sigma_phi`: its std per non-overlapping window (the
  phase-screen surrogate's calibration target, re-exported by
  :mod:`scintrack.signals.phase_screen`);
* :func:`sigma_phi_windows`: sigma_phi per non-overlapping window with window
  centre times; ``window_s = 60`` is Phi60.  ``causal=True`` filters with
  ``sosfilt`` as a real-time ISMR does, so the first windows carry the
  filter's start-up transient (the chapter's Septentrio Phi60 misses the first
  four minutes while its detrending filter converges, Sec. 4); ``skip_s``
  drops that start;
* :func:`phi3_sliding`: Phi3, the std of the causally detrended phase over a
  sliding 3-s window ending at each sample (Susi 2014, Sec. 3: "computed by a
  sliding window in order to get an update value at each time of
  integration"), the SAKF PLL's gain-weighting input.

Variances are population variances (ddof = 0), as ``np.std`` and the trackers'
:func:`scintrack.estimators.formulas.window_mean_var`.  scipy is imported inside
the functions so that importing the package stays light.
"""

from __future__ import annotations

import numpy as np

from . import formulas


def detrend_sos(ts: float, cutoff_hz: float = 0.1, order: int = 6) -> np.ndarray:
    """SOS (n_sections, 6) of the Butterworth high-pass of ``order`` at ``cutoff_hz`` for sampling interval ``ts``."""
    from scipy import signal  # imported where used: keeps importing the package (DAG parsing) light

    return signal.butter(order, cutoff_hz, btype="highpass", fs=1.0 / ts, output="sos")


def detrend_phase(theta: np.ndarray, ts: float, cutoff_hz: float = 0.1) -> np.ndarray:
    """Phase high-passed by a zero-phase 6th-order Butterworth at ``cutoff_hz`` (the ISM receivers' detrending)."""
    from scipy import signal  # imported where used: keeps importing the package (DAG parsing) light

    return signal.sosfiltfilt(detrend_sos(ts, cutoff_hz), theta)


def window_sigma_phi(theta: np.ndarray, ts: float, per_window: int, cutoff_hz: float = 0.1) -> np.ndarray:
    """sigma_phi: std of the detrended phase (:func:`detrend_phase`), per window."""
    hp = detrend_phase(theta, ts, cutoff_hz)
    m = hp.size // per_window
    return hp[: m * per_window].reshape(m, per_window).std(axis=1)


def causal_detrend(theta: np.ndarray, ts: float, cutoff_hz: float = 0.1) -> np.ndarray:
    """The same high-pass applied causally (``sosfilt``, zero initial state) along the last axis."""
    from scipy import signal  # imported where used: keeps importing the package (DAG parsing) light

    return signal.sosfilt(detrend_sos(ts, cutoff_hz), np.asarray(theta, dtype=float), axis=-1)


def sigma_phi_windows(
    theta: np.ndarray, ts: float, window_s: float, cutoff_hz: float = 0.1, causal: bool = False, skip_s: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """(window centre times in s, sigma_phi per non-overlapping window) along the last axis.

    The phase is detrended over the whole series (zero-phase, or causally
    with ``causal=True``), the first ``round(skip_s / ts)`` samples are then
    dropped and the rest is cut into windows of ``round(window_s / ts)``
    samples (a partial last window is dropped).  Sample ``n`` is at time
    ``n ts``; a window's time is the mean of its sample times.  ``theta`` is
    1-D or (..., time); sigma_phi has shape (..., n_windows).
    """
    theta = np.asarray(theta, dtype=float)
    if causal:
        hp = causal_detrend(theta, ts, cutoff_hz)
    else:
        from scipy import signal  # imported where used: keeps importing the package (DAG parsing) light

        hp = signal.sosfiltfilt(detrend_sos(ts, cutoff_hz), theta, axis=-1)
    per, skip = int(round(window_s / ts)), int(round(skip_s / ts))
    if per < 1:
        raise ValueError(f"window_s = {window_s:g} s is shorter than one sample (ts = {ts:g} s)")
    m = max(theta.shape[-1] - skip, 0) // per
    hp = hp[..., skip : skip + m * per].reshape(*hp.shape[:-1], m, per)
    times = (skip + per * np.arange(m) + 0.5 * (per - 1)) * ts
    return times, hp.std(axis=-1)


def phi3_sliding(theta: np.ndarray, ts: float, window_s: float = 3.0, cutoff_hz: float = 0.1) -> np.ndarray:
    """Phi3: std of the causally detrended phase over the ``round(window_s / ts)`` samples ending at each sample.

    NaN until the window is full.  Vectorised over leading axes with
    cumulative sums of x and x^2; the variance is the trackers' floored
    window formula (:func:`.formulas.window_variance`), so
    this is what a kernel using ``window_push``/``window_mean_var`` returns
    (to rounding).
    """
    hp = causal_detrend(theta, ts, cutoff_hz)
    n = int(round(window_s / ts))
    if n < 1:
        raise ValueError(f"window_s = {window_s:g} s is shorter than one sample (ts = {ts:g} s)")
    out = np.full(hp.shape, np.nan)
    if hp.shape[-1] < n:
        return out
    zero = np.zeros((*hp.shape[:-1], 1))
    c1 = np.concatenate([zero, np.cumsum(hp, axis=-1)], axis=-1)
    c2 = np.concatenate([zero, np.cumsum(hp * hp, axis=-1)], axis=-1)
    s1 = c1[..., n:] - c1[..., :-n]
    s2 = c2[..., n:] - c2[..., :-n]
    out[..., n - 1 :] = np.sqrt(formulas.window_variance_ufunc(s1, s2, float(n)))
    return out
