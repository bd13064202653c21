"""Every S4 computation of the package (one module).

The amplitude scintillation index ``S4^2 = Var[I] / E[I]^2`` of the intensity
``I = |P|^2``:

* :func:`s4_index`: raw moments of ``|z|^2`` over an axis (no noise, no
  detrending), e.g. of a CSM realisation;
* :func:`window_s4`: ``std(I) / mean(I)`` over consecutive non-overlapping
  windows (the phase-screen surrogate's calibration target);
* :func:`s4_corrected` / :func:`s4_batch`: noise-corrected S4 from the prompt
  intensity moments; :class:`StreamingS4`: the same over a sliding window,
  per trial, as the AEKF-AR's kernel computes it on line;
* :func:`detrended_s4`: the ISMR S4 (reference notes §3.4; the S4 of Susi,
  Andreotti & Aquino 2014, Sec. 2): the intensity divided by its trend, a
  zero-phase 6th-order Butterworth low-pass at 0.1 Hz, then
  ``std(I_det) / mean(I_det)`` per non-overlapping (60-s) window, optionally
  noise-corrected.

Noise correction.  With ``P = A rho e^{j theta} + n`` and ``n ~ CN(0, s2)``
independent of the scintillation:

* ``E[I] = S + s2`` with ``S = A^2 E[rho^2]``;
* ``Var[I] = A^4 Var[rho^2] + 2 S s2 + s2^2``.

So ``S4^2 = Var[rho^2]/E[rho^2]^2 = (Var[I] - 2 S s2 - s2^2) / S^2`` with
``S = E[I] - s2``.  The noise power ``s2`` comes from the M2M4 estimator
(:mod:`scintrack.estimators.cn0`) over a longer window, or is given.
Streaming moments are taken over a sliding window of the last ``window``
epochs, with no detrending (the tracker's input has no slow power trend in our
scenarios).  This is the estimator the AEKF-AR uses to adapt (Vila-Valls
2018, Sec. V-B); the paper cites [65] without giving one.  The scalar formulas
are :func:`scintrack.estimators.formulas.s4_corrected` and
:func:`~scintrack.estimators.formulas.window_variance` (the AEKF-AR's kernel
calls them); the functions here are their array forms.

Not estimable.  When the signal power is not resolvable (``S = E[I] - s2 <=
0.1 s2``) or the estimate is absurd (NaN, or ``S4 >= 2``), the noise-corrected
S4 is NaN, "not estimable" (the bounds and why:
:func:`scintrack.estimators.formulas.s4_corrected`, constants
``formulas.S4_SIGNAL_FRACTION`` and ``formulas.S4_ESTIMABLE_MAX``), never a
number (the floor ``S >= 1e-12`` alone turns an unresolvable signal into
S4 up to 2.7e12 at C/N0 = 10 dB-Hz).  So :func:`s4_corrected`,
:func:`s4_batch`, :func:`detrended_s4` and :class:`StreamingS4` may return
NaN; a caller that aggregates them must use the NaN-aware reductions and say
what fraction was estimable (:func:`estimable_fraction`).  :func:`s4_index`
(no noise: ``s2 = 0``) is NaN only for an S4 >= 2; :func:`window_s4` is the
plain ``std / mean``.  :class:`StreamingS4` keeps, per trial, the last
estimable value (``held``; the prior until the first), which is what the
AEKF-AR's adaptation uses, so a NaN never selects an AR set.
"""

from __future__ import annotations

import numpy as np

from . import formulas
from .window import SlidingSums


def s4_corrected(mean_i: np.ndarray, var_i: np.ndarray, noise_power: np.ndarray | float) -> np.ndarray:
    """Noise-corrected S4 from the intensity mean and variance (:func:`.formulas.s4_corrected`); NaN: not estimable."""
    return formulas.s4_corrected_ufunc(np.asarray(mean_i, dtype=float), np.asarray(var_i, dtype=float), np.asarray(noise_power, dtype=float))


def s4_batch(prompts: np.ndarray, noise_power: float | np.ndarray, axis: int = -1) -> np.ndarray:
    """Noise-corrected S4 of prompts along ``axis`` (``noise_power = 0``: no correction); NaN: not estimable."""
    intensity = np.abs(prompts) ** 2
    return s4_corrected(intensity.mean(axis=axis), intensity.var(axis=axis), np.asarray(noise_power))


def s4_index(z: np.ndarray, axis: int = -1) -> np.ndarray:
    """Empirical S4 of the intensity ``|z|^2`` from its raw moments (no detrending, no noise)."""
    intensity = np.abs(z) ** 2
    m1 = intensity.mean(axis=axis)
    m2 = (intensity**2).mean(axis=axis)
    return s4_corrected(m1, np.maximum(m2 - m1**2, 0.0), 0.0)


def window_s4(intensity: np.ndarray, per_window: int) -> np.ndarray:
    """S4 = std(I)/mean(I) over consecutive non-overlapping windows of ``per_window`` samples."""
    m = intensity.size // per_window
    blocks_ = intensity[: m * per_window].reshape(m, per_window)
    return blocks_.std(axis=1) / blocks_.mean(axis=1)


def estimable_fraction(s4: np.ndarray, axis=None) -> np.ndarray:
    """Fraction of the S4 estimates that are estimable (not NaN), over ``axis``."""
    return np.mean(~np.isnan(np.asarray(s4, dtype=float)), axis=axis)


class StreamingS4:
    """Noise-corrected S4 over the last ``window`` prompts, per trial.

    :meth:`update` returns the estimate (the prior before ``min_epochs``;
    NaN when not estimable); ``held`` is, per trial, the last estimable one
    (the prior until the first), what an adaptive tracker acts on.
    """

    def __init__(self, n_trials: int, window: int, *, prior: float = 0.0, min_epochs: int | None = None):
        self.sums = SlidingSums(n_trials, 2, window)
        self.min_epochs = min_epochs if min_epochs is not None else window
        self.prior = np.full(n_trials, float(prior))
        self.held = self.prior.copy()

    def update(self, prompt: np.ndarray, noise_power: np.ndarray) -> np.ndarray:
        i = np.abs(prompt) ** 2
        sums, count = self.sums.push(np.stack([i, i**2], axis=-1))
        if count < self.min_epochs:
            return self.prior
        mean = sums[:, 0] / count
        var = formulas.window_variance_ufunc(sums[:, 0], sums[:, 1], float(count))
        est = s4_corrected(mean, var, noise_power)
        self.held = np.where(np.isnan(est), self.held, est)
        return est


def detrended_s4(
    intensity: np.ndarray, ts: float, window_s: float = 60.0, cutoff_hz: float = 0.1, noise_power: float | np.ndarray = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """(window centre times in s, S4 per non-overlapping window) of the trend-normalised intensity.

    ``trend`` = 6th-order Butterworth low-pass at ``cutoff_hz`` applied
    zero-phase (``sosfiltfilt``) to ``intensity`` along its last axis,
    ``I_det = I / trend``; per window of ``round(window_s / ts)`` samples
    (a partial last window is dropped; a window's time is the mean of its
    sample times, sample ``n`` at ``n ts``), ``S4 = std(I_det) / mean(I_det)``.

    ``noise_power`` (the thermal-noise power ``s2`` of the prompts whose
    ``|P|^2`` is ``intensity``; scalar or broadcastable to it) is removed with
    :func:`s4_corrected` applied to the moments of ``I_det``: dividing by the
    trend scales signal and noise alike, so the noise power of ``I_det`` is
    ``s2 / trend``, taken as its mean over the window (the trend is nearly
    constant within one).  ``noise_power = 0`` is the uncorrected
    ``std / mean``.  A window whose corrected S4 is not estimable is NaN
    (see the module docstring).
    """
    from scipy import signal  # imported where used: keeps importing the package (DAG parsing) light

    intensity = np.asarray(intensity, dtype=float)
    sos = signal.butter(6, cutoff_hz, btype="lowpass", fs=1.0 / ts, output="sos")
    trend = signal.sosfiltfilt(sos, intensity, axis=-1)
    per = int(round(window_s / ts))
    if per < 1:
        raise ValueError(f"window_s = {window_s:g} s is shorter than one sample (ts = {ts:g} s)")
    m = intensity.shape[-1] // per
    shape = (*intensity.shape[:-1], m, per)
    i_det = (intensity / trend)[..., : m * per].reshape(shape)
    noise_det = (np.broadcast_to(np.asarray(noise_power, dtype=float), intensity.shape) / trend)[..., : m * per].reshape(shape)
    times = (per * np.arange(m) + 0.5 * (per - 1)) * ts
    return times, s4_corrected(i_det.mean(axis=-1), i_det.var(axis=-1), noise_det.mean(axis=-1))
