"""``scipy.signal.lfilter`` of complex rows through a second-order section, compiled, bit for bit.

The CSM's diffuse field is complex white noise through a real 2nd-order
Butterworth filter at the sub-sample rate (:func:`.csm.butterworth`); after
the random numbers it is the largest cost of generating CSM data (~15 CPU-s
of a full run in ``scipy.signal.lfilter``).  scipy filters complex
input in its generic complex loop (``cmplx_filt`` in scipy's
``signal/_lfilter.cc``, direct form II transposed with the state ``Z`` at
rest or ``zi``): for every sample and coefficient it forms ``t = c
conj(a0)`` and adds or subtracts ``(t x) / |a0|^2`` in a fixed order, the
divisions on the recursion's critical path.

:func:`lfilter` performs the same floating-point operations in the same
order for three coefficients (``b`` and ``a`` zero-padded to three, as scipy
pads them), so its output is scipy's bit for bit
(``tests/test_iir.py``: random rows over many magnitudes, zeros of either
sign, infinities and NaNs, ``a0`` of 1, of 3 and complex, with and without
``zi``; a NaN that an infinite input makes may carry the other sign bit,
which x86 takes from whichever operand the compiler put first; white noise
has neither), with two changes that change no bit:

* the products ``t`` depend on the coefficients only, so they are formed
  once instead of once per sample (the same operations on the same values);
* when ``|a0|^2`` is exactly 1 (``scipy.signal.butter`` returns ``a0 = 1``),
  the divisions by it are left out: dividing by 1 returns its operand
  exactly (signalling NaNs aside, which no arithmetic produces).

No fused multiply-add is formed (numba does not contract without
``fastmath``; scipy's loop is built for the x86-64 baseline, without FMA).
Any other shape of filter goes to scipy itself.  Four or more rows side by
side take ~4.5 ns a sample, scipy's loop ~13.7 ns (``docs/performance.md``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

ORDER = 2  # coefficients - 1: the sections this module compiles


GROUP = 4  # rows filtered side by side: their recursions are independent, so the CPU overlaps them


@njit(cache=True, inline="always")
def _step(xr, xi, z0r, z0i, z1r, z1i, t, mag, unit):
    """One sample of scipy's ``cmplx_filt`` for three coefficients; returns ``(y, new Z[0], new Z[1])`` as re/im."""
    b0r, b0i, b1r, b1i, b2r, b2i = t[0, 0], t[0, 1], t[1, 0], t[1, 1], t[2, 0], t[2, 1]
    a1r, a1i, a2r, a2i = t[4, 0], t[4, 1], t[5, 0], t[5, 1]
    if unit:
        yr = z0r + (b0r * xr - b0i * xi)
        yi = z0i + (b0i * xr + b0r * xi)
        # middle delay: Z[0] = Z[1] + b1 x, then -= a1 y
        m0r = z1r + (b1r * xr - b1i * xi)
        m0i = z1i + (b1i * xr + b1r * xi)
        m0r -= a1r * yr - a1i * yi
        m0i -= a1i * yr + a1r * yi
        # last delay: Z[1] = b2 x, then -= a2 y
        m1r = b2r * xr - b2i * xi
        m1i = b2i * xr + b2r * xi
        m1r -= a2r * yr - a2i * yi
        m1i -= a2i * yr + a2r * yi
    else:
        yr = z0r + (b0r * xr - b0i * xi) / mag
        yi = z0i + (b0i * xr + b0r * xi) / mag
        m0r = z1r + (b1r * xr - b1i * xi) / mag
        m0i = z1i + (b1i * xr + b1r * xi) / mag
        m0r -= (a1r * yr - a1i * yi) / mag
        m0i -= (a1i * yr + a1r * yi) / mag
        m1r = (b2r * xr - b2i * xi) / mag
        m1i = (b2i * xr + b2r * xi) / mag
        m1r -= (a2r * yr - a2i * yi) / mag
        m1i -= (a2i * yr + a2r * yi) / mag
    return yr, yi, m0r, m0i, m1r, m1i


@njit(cache=True)
def _sos_rows(x, t, mag, unit, z0, y, zf):
    """Filter every row of ``x`` (rows, n) complex; ``t`` (6, 2): the products (re, im) of ``b0 b1 b2 a0 a1 a2``
    with ``conj(a0)`` (row 3 unused), ``mag = |a0|^2``, ``unit``: ``mag == 1``; ``z0`` (rows, 2) the initial
    state; writes ``y`` and the final state ``zf`` (rows, 2).  Rows go ``GROUP`` at a time (the same operations
    per row), the last ``rows mod GROUP`` one at a time."""
    n_rows, n = x.shape
    s = np.empty((4, GROUP))  # Z[0] re, im, Z[1] re, im of the group's rows
    full = n_rows - n_rows % GROUP
    for r0 in range(0, full, GROUP):
        for g in range(GROUP):
            s[0, g], s[1, g], s[2, g], s[3, g] = z0[r0 + g, 0].real, z0[r0 + g, 0].imag, z0[r0 + g, 1].real, z0[r0 + g, 1].imag
        for k in range(n):
            for g in range(GROUP):
                v = x[r0 + g, k]
                yr, yi, s[0, g], s[1, g], s[2, g], s[3, g] = _step(v.real, v.imag, s[0, g], s[1, g], s[2, g], s[3, g], t, mag, unit)
                y[r0 + g, k] = complex(yr, yi)
        for g in range(GROUP):
            zf[r0 + g, 0], zf[r0 + g, 1] = complex(s[0, g], s[1, g]), complex(s[2, g], s[3, g])
    for r in range(full, n_rows):
        z0r, z0i, z1r, z1i = z0[r, 0].real, z0[r, 0].imag, z0[r, 1].real, z0[r, 1].imag
        for k in range(n):
            v = x[r, k]
            yr, yi, z0r, z0i, z1r, z1i = _step(v.real, v.imag, z0r, z0i, z1r, z1i, t, mag, unit)
            y[r, k] = complex(yr, yi)
        zf[r, 0], zf[r, 1] = complex(z0r, z0i), complex(z1r, z1i)


def lfilter(b, a, x: np.ndarray, zi: np.ndarray | None = None):
    """``scipy.signal.lfilter(b, a, x, axis=-1, zi=zi)`` for complex 2-D ``x`` (rows, samples); the same values.

    The compiled loop (:func:`_sos_rows`) runs when ``x`` is complex128 and 2-D, the longer of ``b`` and ``a``
    has three coefficients (scipy's loop for fewer differs), ``a`` more than one, ``a[0] != 0`` and ``zi`` is None
    or (rows, 2); anything else is handed to scipy.
    Returns ``y`` or, with ``zi``, ``(y, zf)`` as scipy does.
    """
    b_arr, a_arr = np.atleast_1d(np.asarray(b)), np.atleast_1d(np.asarray(a))
    x_arr = np.asarray(x)
    fits = (x_arr.dtype == np.complex128 and x_arr.ndim == 2 and b_arr.ndim == 1 and a_arr.ndim == 1 and a_arr.size > 1
            and max(a_arr.size, b_arr.size) == ORDER + 1 and b_arr.dtype.kind in "fc" and a_arr.dtype.kind in "fc" and a_arr[0] != 0
            and (zi is None or np.shape(zi) == (x_arr.shape[0], ORDER)))
    if not fits:
        from scipy import signal

        return signal.lfilter(b, a, x, axis=-1) if zi is None else signal.lfilter(b, a, x, axis=-1, zi=zi)
    coef = np.zeros((2, ORDER + 1), dtype=complex)  # b and a cast to complex and zero-filled, as scipy does
    coef[0, : b_arr.size], coef[1, : a_arr.size] = b_arr, a_arr
    a0r, a0i = coef[1, 0].real, coef[1, 0].imag
    re, im = coef.real.ravel(), coef.imag.ravel()
    t = np.empty((2 * (ORDER + 1), 2))
    t[:, 0] = re * a0r + im * a0i  # scipy's tmpr and tmpi, per coefficient (b0 b1 b2 a0 a1 a2)
    t[:, 1] = im * a0r - re * a0i
    mag = a0r * a0r + a0i * a0i
    x_c = np.ascontiguousarray(x_arr)
    y = np.empty(x_c.shape, dtype=complex)
    zf = np.empty((x_c.shape[0], ORDER), dtype=complex)
    z0 = np.zeros((x_c.shape[0], ORDER), dtype=complex) if zi is None else np.ascontiguousarray(zi, dtype=complex)
    _sos_rows(x_c, t, float(mag), bool(mag == 1.0), z0, y, zf)
    return y if zi is None else (y, zf)
