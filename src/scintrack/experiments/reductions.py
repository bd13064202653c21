"""Compiled (numba) loops over the (trials, epochs) arrays of an experiment's results.

The cycle-slip counter, the derotated block sums and the phase wrap of
:mod:`.metrics`, the median over trials of the runner
(:class:`.runner.TrialMedian`) and the scans of the divergence guards
(:func:`.guards.detect`).  Each gives what its numpy form gives without the
numpy form's full-size temporaries: bit for bit, except the wrap, which
reduces by whole periods instead of going through sin, cos and atan2, and so
agrees with ``angle(exp(j e))`` to the last place (``tests/test_speed_paths.py``).
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core.extending import intrinsic


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


@intrinsic
def fma(typingctx, a, b, c):
    """``a * b + c`` rounded once (LLVM's ``llvm.fma.f64``), for float64 arguments."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        d = ir.DoubleType()
        return builder.call(builder.module.declare_intrinsic("llvm.fma", [d], ir.FunctionType(d, [d, d, d])), args)

    return sig, codegen


#: numpy's pairwise summation: blocks of up to this many float64 (re and im of a complex count two) are summed
#: with eight accumulators, longer runs are split in two (numpy's ``PW_BLOCKSIZE``).
PW_BLOCKSIZE = 128


@njit(cache=True)
def _derotated(y, phase, t, i):
    """``y[t, i] * exp(-j phase[t, i])`` as numpy computes ``y * numpy.exp(-1j * phase)`` for arrays of 256 KiB
    and more: libm's cos and sin (numpy's complex ``exp`` of an imaginary argument), and numpy's complex
    product on a CPU with FMA (x86-64-v3 and later) with the phasor as first operand ``a`` (numpy reuses
    that temporary as the output) and ``y`` as ``b``:
    ``re = fma(a.re, b.re, -(a.im b.im))``, ``im = fma(a.re, b.im, a.im b.re)``."""
    c = math.cos(phase[t, i])
    ms = -math.sin(phase[t, i])
    b = y[t, i]
    return fma(c, b.real, -(ms * b.imag)), fma(c, b.imag, ms * b.real)


@njit(cache=True)
def _pairwise_derotated(y, phase, t, lo, m):
    """Sum of ``m`` derotated values from epoch ``lo`` of row ``t`` in numpy's pairwise order for complex
    (``pairwise_sum`` over ``n = 2 m`` interleaved float64: re and im accumulate separately)."""
    n = 2 * m
    if n < 8:
        rr, ri = -0.0, -0.0
        for k in range(m):
            pr, pi = _derotated(y, phase, t, lo + k)
            rr += pr
            ri += pi
        return rr, ri
    if n <= PW_BLOCKSIZE:
        r0, r1 = _derotated(y, phase, t, lo)
        r2, r3 = _derotated(y, phase, t, lo + 1)
        r4, r5 = _derotated(y, phase, t, lo + 2)
        r6, r7 = _derotated(y, phase, t, lo + 3)
        k = 4
        while 2 * k < n - (n % 8):
            pr, pi = _derotated(y, phase, t, lo + k)
            r0 += pr
            r1 += pi
            pr, pi = _derotated(y, phase, t, lo + k + 1)
            r2 += pr
            r3 += pi
            pr, pi = _derotated(y, phase, t, lo + k + 2)
            r4 += pr
            r5 += pi
            pr, pi = _derotated(y, phase, t, lo + k + 3)
            r6 += pr
            r7 += pi
            k += 4
        rr = (r0 + r2) + (r4 + r6)
        ri = (r1 + r3) + (r5 + r7)
        while k < m:
            pr, pi = _derotated(y, phase, t, lo + k)
            rr += pr
            ri += pi
            k += 1
        return rr, ri
    n2 = n // 2
    n2 -= n2 % 8
    ar, ai = _pairwise_derotated(y, phase, t, lo, n2 // 2)
    br, bi = _pairwise_derotated(y, phase, t, lo + n2 // 2, m - n2 // 2)
    return ar + br, ai + bi


@njit(cache=True)
def derotated_sums_kernel(y, phase, start, per, out):
    """``out[t, b] = sum(y[t, i] exp(-j phase[t, i]))`` over ``i = start + b per .. start + (b + 1) per - 1``.

    The values numpy gives for ``(y * numpy.exp(-1j * phase))[:, start:start + nb per].reshape(-1, nb, per).sum(-1)``
    with arrays of 256 KiB and more on a CPU with FMA, bit for bit (``tests/test_speed_paths.py``), without its
    four (trials, epochs) temporaries.  numpy's own bits for that expression depend on the array size: from
    256 KiB it computes the product in the phasor's temporary (operands swapped, a different rounding of
    the imaginary part), below it into a new array; on a CPU without FMA its product rounds twice.  The
    sums agree with either to a few units in the last place, and what the callers keep (a sign, a lock
    test) is the same unless a sum sits within that of its threshold.
    """
    n_tr, nb = out.shape
    for t in range(n_tr):
        for b in range(nb):
            rr, ri = _pairwise_derotated(y, phase, t, start + b * per, per)
            out[t, b] = complex(0.0 + rr, 0.0 + ri)  # numpy's reduction adds the pairwise sum to its initial 0


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
