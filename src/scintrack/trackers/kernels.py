"""Compiled (numba) loops that are not trackers: the cycle-slip counter,
the unit phasors and the phase wrap of :mod:`scintrack.experiments.metrics`, the median over
trials of the runner (:class:`scintrack.experiments.runner.TrialMedian`) and
the scans of the divergence guards (:func:`scintrack.experiments.guards.detect`).
Each gives what its numpy form gives without the numpy form's full-size
temporaries: bit for bit, except the wrap, which reduces by whole periods
instead of going through sin, cos and atan2, and so agrees with
``angle(exp(j e))`` to the last place (``tests/test_speed_paths.py``).

The trackers' kernels live in their own modules (:mod:`.pll`, :mod:`.kf`,
:mod:`.aekf_ar`) and are made of the building blocks in :mod:`.blocks`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def cycle_slip_kernel(e, hysteresis, settle):
    """Cycles slipped and slip events per trial (see experiments.metrics)."""
    n, k = e.shape
    two_pi = 2.0 * math.pi
    limit = math.pi + hysteresis
    cycles = np.zeros(n, dtype=np.int64)
    events = np.zeros(n, dtype=np.int64)
    for t in range(n):
        level = np.round(e[t, 0] / two_pi)
        in_event = False
        calm = 0
        for i in range(1, k):
            if abs(e[t, i] - two_pi * level) >= limit:
                new = np.round(e[t, i] / two_pi)
                cycles[t] += int(abs(new - level))
                level = new
                if not in_event:
                    events[t] += 1
                    in_event = True
                calm = 0
            elif in_event:
                calm += 1
                if calm >= settle:
                    in_event = False
    return cycles, events


@njit(cache=True)
def sin_cos_kernel(e, s, c):
    """``s = sin(e)``, ``c = cos(e)`` element by element (1-D, contiguous).

    The same libm calls that numpy's complex ``exp`` makes for a purely
    imaginary argument, so ``c + j s`` equals ``numpy.exp(1j * e)`` bit for
    bit (``tests/test_speed_paths.py``), without the two complex temporaries.
    """
    for i in range(e.size):
        s[i] = math.sin(e[i])
        c[i] = math.cos(e[i])


#: 2 pi split for an exact reduction (Cody-Waite): ``TWO_PI_HI`` has 33 significant bits, so ``k * TWO_PI_HI``
#: is exact for |k| < 2**20 cycles; ``TWO_PI_LO = 2 pi - TWO_PI_HI`` to double precision.
TWO_PI_HI = float.fromhex("0x1.921fb544p+2")
TWO_PI_LO = 2.430840202602477e-10


@njit(cache=True)
def wrap_kernel(e, out):
    """``out = e`` wrapped to [-pi, pi] by whole cycles (1-D, contiguous).

    A value already in [-pi, pi] is copied as it is (the tracking errors of a
    loop in lock: no arithmetic at all); any other finite value ``x`` becomes
    ``x - 2 pi k`` with ``k`` the nearest whole number of cycles, the product
    split in two parts (:data:`TWO_PI_HI`, :data:`TWO_PI_LO`) so that the
    result is within a few units in the last place of the exact reduction
    (one for |x| < 1000); from a million cycles on, where that split is no
    longer exact, ``atan2(sin x, cos x)`` with libm's exact argument
    reduction; NaN and +-inf give NaN.  This is ``angle(exp(j e))`` up to
    that last place, which numpy's libm route (``arctan2(sin e, cos e)``)
    also only gives to a last place or so.
    """
    two_pi = 2.0 * math.pi
    for i in range(e.size):
        x = e[i]
        if -math.pi <= x <= math.pi:
            out[i] = x
        elif abs(x) < 1e6 * two_pi:
            k = math.floor(x / two_pi + 0.5)
            r = (x - k * TWO_PI_HI) - k * TWO_PI_LO
            if r > math.pi:
                r = (r - TWO_PI_HI) - TWO_PI_LO
            elif r < -math.pi:
                r = (r + TWO_PI_HI) + TWO_PI_LO
            out[i] = r
        elif math.isfinite(x):  # a million cycles or more: libm's exact argument reduction
            out[i] = math.atan2(math.sin(x), math.cos(x))
        else:
            out[i] = math.nan


@njit(cache=True)
def column_nanmedian_kernel(v, out):
    """``out[j] = numpy.nanmedian(v[:, j])`` for a 2-D float array ``v`` (rows: trials), NaN for an all-NaN column.

    numpy's own ``nanmedian(v, axis=0)`` over fewer than 600 rows goes through
    masked arrays (a full argsort of ``v`` and several copies of its size:
    ~0.5 s and ~0.3 GB for 25 x 300 000).  Here each column's finite-or-inf
    values are gathered, sorted, and the median is ``(low + high) / 2`` of the
    two middle values (the same one for an odd count), the same two
    operations numpy's masked median makes, so the values are the same bits
    (``tests/test_speed_paths.py``).
    """
    n, k = v.shape
    buf = np.empty(n)
    for j in range(k):
        c = 0
        for i in range(n):
            x = v[i, j]
            if not math.isnan(x):
                buf[c] = x
                c += 1
        if c == 0:
            out[j] = np.nan
            continue
        s = buf[:c]
        s.sort()  # in place: no array per column
        h = c // 2
        lo = h if c % 2 == 1 else h - 1
        out[j] = (s[lo] + s[h]) / 2.0


@njit(cache=True)
def first_nonfinite_kernel(v, is_phase, limit, first):
    """Lower ``first[t]`` (-1: none yet) to the first epoch of row ``t`` where ``v`` is NaN or inf, or, for a phase, beyond ``limit``.

    One pass that stops at the row's current ``first`` (the guards of
    :mod:`scintrack.experiments.guards` take the earliest over several arrays).
    """
    n, k = v.shape
    for t in range(n):
        stop = k if first[t] < 0 else first[t]
        for i in range(stop):
            x = v[t, i]
            if not math.isfinite(x) or (is_phase and abs(x) > limit):
                first[t] = i
                break


@njit(cache=True)
def first_step_kernel(v, limit, first):
    """Lower ``first[t]`` to the first epoch ``i >= 2`` of row ``t`` with ``|(v_i - v_{i-1}) - (v_{i-1} - v_{i-2})| > limit``.

    The same two subtractions as ``numpy.diff(v, n=2)``; a NaN compares False.
    """
    n, k = v.shape
    for t in range(n):
        stop = k if first[t] < 0 else first[t]
        for i in range(2, stop):
            if abs((v[t, i] - v[t, i - 1]) - (v[t, i - 1] - v[t, i - 2])) > limit:
                first[t] = i
                break
