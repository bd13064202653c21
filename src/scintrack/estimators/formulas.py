"""The scalar formulas of the on-line estimators, compiled once for the array code and the tracker kernels.

* M2M4 signal/noise split (GNSS-SDR ``cn0_m2m4_estimator``):
  :func:`m2m4_signal_power`, :func:`m2m4_split`; C/N0 from the powers,
  ``C/N0 = Pd / (Pn Ts)``: :func:`cn0_from_powers` (:mod:`.cn0`);
* sliding-window running sums (ring buffers, exact re-sum once per lap):
  :func:`window_push`; the window's mean and floored variance:
  :func:`window_variance`, :func:`window_mean_var` (:mod:`.window`);
* noise-corrected S4 from intensity moments (Vila-Valls et al. 2018,
  Sec. V-B), NaN when not estimable: :func:`s4_corrected` (:mod:`.s4`).

Each is an ``@njit`` function that the tracker kernels call (numba inlines
it; never turn fastmath on here), and its ``*_ufunc`` is the numpy ufunc
compiled from the same Python function (:class:`scintrack.simd.ufunc.LazyUfunc`),
which the estimators' array forms call.  The formulas compile for ``Lanes``
arguments too (:mod:`scintrack.simd.lanes`) and give, lane by lane, the bits
of the scalar call.  They live here, with the estimators, because that is
what they are; the trackers use the estimators, never the reverse.
"""

from __future__ import annotations

import math

from numba import njit

from ..simd.lanes import select_less
from ..simd.ufunc import F8_3, LazyUfunc

__all__ = [
    "S4_ESTIMABLE_MAX",
    "S4_SIGNAL_FRACTION",
    "cn0_from_powers",
    "cn0_from_powers_ufunc",
    "m2m4_signal_power",
    "m2m4_signal_power_ufunc",
    "m2m4_split",
    "s4_corrected",
    "s4_corrected_ufunc",
    "window_mean_var",
    "window_push",
    "window_variance",
    "window_variance_ufunc",
]

# --- M2M4 and C/N0 ---------------------------------------------------------------


def _m2m4_signal_power(m2, m4, floor_fraction):
    pd = math.sqrt(max(2.0 * m2 * m2 - m4, (floor_fraction * m2) ** 2))
    return min(pd, (1.0 - floor_fraction) * m2)


m2m4_signal_power = njit(cache=True)(_m2m4_signal_power)
m2m4_signal_power_ufunc = LazyUfunc(_m2m4_signal_power, F8_3)


@njit(cache=True)
def m2m4_split(m2, m4, floor_fraction):
    """(signal power, noise power) from the 2nd and 4th moments of |P|."""
    pd = m2m4_signal_power(m2, m4, floor_fraction)
    return pd, m2 - pd


def _cn0_from_powers(signal_power, noise_power, ts):
    return signal_power / (noise_power * ts)


cn0_from_powers = njit(cache=True)(_cn0_from_powers)
cn0_from_powers_ufunc = LazyUfunc(_cn0_from_powers, F8_3)


# --- sliding windows and S4 ------------------------------------------------------


@njit(cache=True)
def window_push(b1, b2, pos, s1, s2, count, v1, v2):
    """Push (v1, v2) into two ring buffers with running sums; exact re-sum once per lap."""
    s1 += v1 - b1[pos]
    s2 += v2 - b2[pos]
    b1[pos] = v1
    b2[pos] = v2
    pos = (pos + 1) % b1.size
    count = min(count + 1, b1.size)
    if pos == 0:
        s1 = b1.sum()
        s2 = b2.sum()
    return pos, s1, s2, count


def _window_variance(s1, s2, count):
    mean = s1 / count
    return max(s2 / count - mean * mean, 0.0)


window_variance = njit(cache=True)(_window_variance)
window_variance_ufunc = LazyUfunc(_window_variance, F8_3)


@njit(cache=True)
def window_mean_var(s1, s2, count):
    """Mean and (floored) variance from the window sums of x and x^2."""
    return s1 / count, window_variance(s1, s2, count)


#: "not estimable" below: the signal power ``mean(I) - s2`` is at most this fraction of the noise power ``s2``
S4_SIGNAL_FRACTION = 0.1
#: "not estimable" at and above: an S4 no fading model reaches (Nakagami-m, m >= 1/2: S4 <= sqrt 2)
S4_ESTIMABLE_MAX = 2.0


def _s4_corrected(mean_i, var_i, noise_power):
    """Noise-corrected S4 (:mod:`scintrack.estimators.s4`), NaN when not estimable.

    ``S4^2 = (var_i - 2 S s2 - s2^2) / S^2`` with ``S = mean_i - s2`` (floored
    at 1e-12, a negative ``S4^2`` floored at 0).  NaN ("not
    estimable") when

    * ``S <= S4_SIGNAL_FRACTION * s2`` (0.1): the signal part of the intensity
      variance, ``S^2 S4^2 <= 0.01 s2^2`` even at S4 = 1, is below the sampling
      error of the variance of a noise-dominated intensity, ``~ s2^2
      sqrt(8 / N)``, for every window shorter than N = 8e4 epochs (the
      on-line window is 1e3-1e4); below it the estimate is noise (at 10
      dB-Hz and 10 ms, ``S / s2 = 0.1``; the 1e-12 floor alone gave S4 up to
      2.7e12);
    * the S4 is NaN or ``>= S4_ESTIMABLE_MAX`` (2): above any fading model
      (Nakagami-m with m >= 1/2, the family's limit, has S4 <= sqrt 2 = 1.41;
      the CSM realises S4 <= 1, the phase screen saturates near 1), with a
      margin of 40 % for the sampling error of a window estimate.

    Elsewhere the value is the formula's.  The tests are :func:`select_less`
    (ordered compares: a NaN input fails them and gives NaN), so the same
    formula compiles for Lanes.
    """
    sig = max(mean_i - noise_power, 1e-12)
    s4sq = (var_i - 2.0 * sig * noise_power - noise_power * noise_power) / (sig * sig)
    s4 = math.sqrt(max(s4sq, 0.0))
    return select_less(S4_SIGNAL_FRACTION * noise_power, sig, select_less(s4, S4_ESTIMABLE_MAX, s4, math.nan), math.nan)


s4_corrected = njit(cache=True)(_s4_corrected)
s4_corrected_ufunc = LazyUfunc(_s4_corrected, F8_3)
