"""Carrier-phase discriminators and their noise variances.

* ATAN2 discriminator ``atan2(Q, I)`` of the prompt against the replica phase:
  :func:`atan2_discriminator`; its data-insensitive (Costas) form ``atan(Q/I)``:
  :func:`atan_discriminator`;
* the ATAN2 discriminator's variance at ``x = 2 C/N0 Ts`` (Vila-Valls et al.
  2018, eq. 12): :func:`atan_variance`; the Costas discriminator's, Susi et al.
  2014, eq. (10): :func:`costas_variance`;
* the same on lanes (one SIMD evaluation for ``LANES`` trials):
  :func:`atan2_discriminator_lanes`, :func:`atan_discriminator_lanes`, and with
  the gather of the epoch's prompts: :func:`prompt_discriminator_lanes`.

The sine, cosine and arctangents are :mod:`scintrack.trackers.trig`'s (plain
IEEE arithmetic), so the scalar, lane and ufunc (``*_ufunc``) forms of a
discriminator give the same bits.
"""

from __future__ import annotations

import math

from numba import njit

from ...simd import LANES
from ...simd.lanes import lane_load, lane_store
from ...simd.ufunc import F8_2, F8_3, LazyUfunc
from .. import trig

__all__ = [
    "atan2_discriminator",
    "atan2_discriminator_lanes",
    "atan2_discriminator_ufunc",
    "atan_discriminator",
    "atan_discriminator_lanes",
    "atan_discriminator_ufunc",
    "atan_variance",
    "atan_variance_ufunc",
    "costas_variance",
    "costas_variance_ufunc",
    "prompt_discriminator_lanes",
]

# --- ATAN2 discriminator --------------------------------------------------------


def _atan2_discriminator(yr, yi, phase):
    s_, c_ = trig.sincos(phase)
    return trig.atan2(yi * c_ - yr * s_, yr * c_ + yi * s_)


atan2_discriminator = njit(cache=True)(_atan2_discriminator)
atan2_discriminator_ufunc = LazyUfunc(_atan2_discriminator, F8_3)


def _atan_discriminator(yr, yi, phase):
    """Costas (two-quadrant) ``atan(Q/I)``: insensitive to the data bit, error in [-pi/2, pi/2] (``I = 0``: +-pi/2)."""
    s_, c_ = trig.sincos(phase)
    i_ = yr * c_ + yi * s_
    q_ = yi * c_ - yr * s_
    return trig.atan(q_, i_)


atan_discriminator = njit(cache=True)(_atan_discriminator)
atan_discriminator_ufunc = LazyUfunc(_atan_discriminator, F8_3)


# --- eq. (12): discriminator variance ---------------------------------------


def _atan_variance(cn0_hz, ts):
    x = max(2.0 * cn0_hz * ts, 1e-6)
    return (math.exp(-0.8 * math.sqrt(x)) + 1.0) * math.erf(0.4 * x) / x


atan_variance = njit(cache=True)(_atan_variance)
atan_variance_ufunc = LazyUfunc(_atan_variance, F8_2)


# --- Susi et al. 2014, eq. (10) -------------------------------------------------


def _costas_variance(cn0_hz, ts):
    """Susi eq. (10): ``R = 1/(2 C/N0 Ts) (1 + 1/(2 C/N0 Ts))`` [rad^2], the atan discriminator's variance."""
    x = max(2.0 * cn0_hz * ts, 1e-6)
    return (1.0 + 1.0 / x) / x


costas_variance = njit(cache=True)(_costas_variance)
costas_variance_ufunc = LazyUfunc(_costas_variance, F8_2)


# --- on lanes ---------------------------------------------------------------------


@njit(cache=True)
def atan2_discriminator_lanes(yr, yi, phase, out):
    """``out[ln] = atan2_discriminator(yr[ln], yi[ln], phase[ln])`` on every lane (one SIMD evaluation); arrays (LANES,)."""
    L = LANES
    if yr.shape != (L,) or yi.shape != (L,) or phase.shape != (L,) or out.shape != (L,):
        raise ValueError("atan2_discriminator_lanes: arrays must be (LANES,)")
    lane_store(out, 0, atan2_discriminator(lane_load(yr, 0), lane_load(yi, 0), lane_load(phase, 0)))


@njit(cache=True)
def atan_discriminator_lanes(yr, yi, phase, out):
    """``out[ln] = atan_discriminator(yr[ln], yi[ln], phase[ln])`` on every lane (one SIMD evaluation); arrays (LANES,)."""
    L = LANES
    if yr.shape != (L,) or yi.shape != (L,) or phase.shape != (L,) or out.shape != (L,):
        raise ValueError("atan_discriminator_lanes: arrays must be (LANES,)")
    lane_store(out, 0, atan_discriminator(lane_load(yr, 0), lane_load(yi, 0), lane_load(phase, 0)))


@njit(cache=True)
def prompt_discriminator_lanes(y, trial, i, phase, costas, yr, yi, out):
    """Epoch ``i`` of every lane's trial, ``y[trial[ln], i]``, into ``yr``/``yi`` (LANES,) and its discriminator
    against ``phase`` into ``out``: :func:`atan_discriminator` (Costas, ``costas``) or :func:`atan2_discriminator`."""
    for ln in range(LANES):
        v = y[trial[ln], i]
        yr[ln], yi[ln] = v.real, v.imag
    if costas:
        atan_discriminator_lanes(yr, yi, phase, out)
    else:
        atan2_discriminator_lanes(yr, yi, phase, out)

