"""The AEKF-AR's steps (Vila-Valls et al. 2018, Sec. IV-V), on lanes.

* eqs. (8), (11) prediction with F = blkdiag(dynamics, AR companion, AR
  companion), using that structure: :func:`ar_predict` (its per-set
  coefficients: :func:`ar_coefficients`; flop count: :func:`ar_predict_flops`);
* eqs. (13)-(14) I/Q (2 x 2) EKF update with the Jacobian of ``h(x) = A rho_s
  [cos(theta_d + theta_s), sin(theta_d + theta_s)]`` in closed form:
  :func:`iq_update` (flop count: :func:`iq_update_flops`);
* the mirror fold (an isolating option, not in the paper): :func:`fold_mirror`;
* nearest adaptation point (Sec. V-B): :func:`nearest_index`, on lanes
  :func:`nearest_index_lanes`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...simd import LANES
from ...simd.lanes import lane_load, lane_splat, lane_store, lane_where_less, lanes_any_zero
from .. import trig

__all__ = [
    "C_AR",
    "C_F01",
    "C_F02",
    "C_F12",
    "C_KAP",
    "C_QD",
    "C_QR",
    "C_QT",
    "ar_coefficients",
    "ar_predict",
    "ar_predict_flops",
    "fold_mirror",
    "iq_update",
    "iq_update_flops",
    "nearest_index",
    "nearest_index_lanes",
]

# rows of the per-set coefficient table of ar_predict (ar_coefficients)
C_F01, C_F02, C_F12 = 0, 1, 2  # F_d[0, 1], F_d[0, 2], F_d[1, 2]
C_QD = 3  # Q_d, 9 entries row-major
C_QT, C_QR, C_KAP = 12, 13, 14  # Q[3, 3], Q[ir, ir], kappa (on the rho_s,k row)
C_AR = 15  # beta_1..beta_p, then gamma_1..gamma_q


def ar_coefficients(F: np.ndarray, Q: np.ndarray, kap: np.ndarray, p: int, q: int) -> np.ndarray:
    """Per-set coefficient rows (sets, C_AR + p + q) of :func:`ar_predict`, from stacked F, Q, kappa.

    Checks that F is ``blkdiag(F_d, companion(beta), companion(gamma))`` with
    ``F_d`` upper triangular with a unit diagonal (eq. 8), that Q is
    ``blkdiag(Q_d, sigma_theta^2, 0.., sigma_rho^2, 0..)`` and that kappa sits on
    the rho_s,k row only (eq. 11): the structure :func:`ar_predict` assumes.
    """
    F, Q, kap = (np.asarray(a, dtype=float) for a in (F, Q, kap))
    n, ir = 3 + p + q, 3 + p
    if p < 1 or q < 1:
        raise ValueError(f"the state needs at least one phase and one amplitude lag (p = {p}, q = {q})")
    if F.ndim != 3 or F.shape[1:] != (n, n) or Q.shape != F.shape or kap.shape != F.shape[:2]:
        raise ValueError(f"F, Q, kappa must be (sets, {n}, {n}), (sets, {n}, {n}), (sets, {n})")
    co = np.zeros((F.shape[0], C_AR + p + q))
    for j in range(F.shape[0]):
        f = np.zeros((n, n))
        f[:3, :3] = np.triu(F[j, :3, :3])
        np.fill_diagonal(f[:3, :3], 1.0)
        f[3, 3:ir], f[ir, ir:] = F[j, 3, 3:ir], F[j, ir, ir:]
        for a in (*range(4, ir), *range(ir + 1, n)):
            f[a, a - 1] = 1.0
        qq = np.zeros((n, n))
        qq[:3, :3], qq[3, 3], qq[ir, ir] = Q[j, :3, :3], Q[j, 3, 3], Q[j, ir, ir]
        kk = np.zeros(n)
        kk[ir] = kap[j, ir]
        if not (np.array_equal(f, F[j]) and np.array_equal(qq, Q[j]) and np.array_equal(kk, kap[j])):
            raise ValueError(f"set {j}: F, Q or kappa is not of the [dynamics, AR(p) companion, AR(q) companion] form")
        co[j, C_F01], co[j, C_F02], co[j, C_F12] = F[j, 0, 1], F[j, 0, 2], F[j, 1, 2]
        co[j, C_QD : C_QD + 9] = Q[j, :3, :3].ravel()
        co[j, C_QT], co[j, C_QR], co[j, C_KAP] = Q[j, 3, 3], Q[j, ir, ir], kap[j, ir]
        co[j, C_AR : C_AR + p], co[j, C_AR + p :] = F[j, 3, 3:ir], F[j, ir, ir:]
    return co


@njit(cache=True)
def ar_predict(x, P, xn, Pn, G, co, p, q):
    """``xn = F x + kappa``, ``Pn = F P F^T + Q`` on lanes, F = blkdiag(F_d, companion(beta), companion(gamma)).

    ``co`` (C_AR + p + q, LANES): each lane's coefficients (:func:`ar_coefficients`);
    ``G`` (4, n, LANES): work array; ``xn``/``Pn`` must not be ``x``/``P`` (swap them after).

    Structure: rows 2, 4..ir-1 and ir+1..n-1 of F select one row of what they
    multiply, so only rows 0, 1, 3 and ir of ``F P`` (``G``) and columns 0, 1,
    2, 3 and ir of ``(F P) F^T`` take arithmetic; the lag shifts are copies.
    Each entry is the sum :func:`predict` forms, over the same non-zeros in the
    same order (``Q`` first on the right product, ``kappa`` or 0 first for x),
    with the unit entries of F taken exactly (``1 v = v``).  So x is
    :func:`predict`'s bit for bit and P too, up to the sign of exact zeros: an
    exact-zero AR coefficient (the padding of a lower order) adds an exact +-0
    instead of being skipped, and a shifted zero is not renormalised to +0 (no
    operation downstream of P distinguishes -0 from +0, and x never gets a -0).
    Flop count: :func:`ar_predict_flops`.
    """
    L = LANES
    n = 3 + p + q
    ir = 3 + p
    b0 = C_AR  # beta_1
    g0 = C_AR + p  # gamma_1
    if (p < 1 or q < 1 or x.shape != (n, L) or xn.shape != (n, L) or P.shape != (n, n, L) or Pn.shape != (n, n, L)
            or G.shape != (4, n, L) or co.shape != (C_AR + p + q, L)):
        raise ValueError("ar_predict: arrays must be x, xn (n, LANES), P, Pn (n, n, LANES), G (4, n, LANES), co (C_AR + p + q, LANES)")
    f01 = lane_load(co, C_F01 * L)
    f02 = lane_load(co, C_F02 * L)
    f12 = lane_load(co, C_F12 * L)
    # G = rows 0, 1, 3 and ir of F P
    for c in range(n):
        p0 = lane_load(P, c * L)
        p1 = lane_load(P, (n + c) * L)
        p2 = lane_load(P, (2 * n + c) * L)
        lane_store(G, c * L, (p0 + f01 * p1) + f02 * p2)
        lane_store(G, (n + c) * L, p1 + f12 * p2)
        acc = lane_load(co, b0 * L) * lane_load(P, (3 * n + c) * L)
        for j in range(1, p):
            acc = acc + lane_load(co, (b0 + j) * L) * lane_load(P, ((3 + j) * n + c) * L)
        lane_store(G, (2 * n + c) * L, acc)
        acc = lane_load(co, g0 * L) * lane_load(P, (ir * n + c) * L)
        for j in range(1, q):
            acc = acc + lane_load(co, (g0 + j) * L) * lane_load(P, ((ir + j) * n + c) * L)
        lane_store(G, (3 * n + c) * L, acc)
    # Pn = (F P) F^T + Q row by row; row a of F P is a row of G or, for a selection row, of P
    for a in range(n):
        if a == 0 or a == 1:
            R, r = G, a
        elif a == 3:
            R, r = G, 2
        elif a == ir:
            R, r = G, 3
        elif a == 2:
            R, r = P, 2
        else:
            R, r = P, a - 1
        o = r * n * L  # row r of R
        w = a * n * L  # row a of Pn
        r0 = lane_load(R, o)
        r1 = lane_load(R, o + L)
        r2 = lane_load(R, o + 2 * L)
        if a < 3:
            qa = (C_QD + 3 * a) * L
            lane_store(Pn, w, ((lane_load(co, qa) + r0) + f01 * r1) + f02 * r2)
            lane_store(Pn, w + L, (lane_load(co, qa + L) + r1) + f12 * r2)
            lane_store(Pn, w + 2 * L, lane_load(co, qa + 2 * L) + r2)
        else:
            lane_store(Pn, w, (r0 + f01 * r1) + f02 * r2)
            lane_store(Pn, w + L, r1 + f12 * r2)
            lane_store(Pn, w + 2 * L, r2)
        acc = lane_load(co, b0 * L) * lane_load(R, o + 3 * L)
        if a == 3:
            acc = lane_load(co, C_QT * L) + acc
        for j in range(1, p):
            acc = acc + lane_load(co, (b0 + j) * L) * lane_load(R, o + (3 + j) * L)
        lane_store(Pn, w + 3 * L, acc)
        for b in range(4, ir):
            lane_store(Pn, w + b * L, lane_load(R, o + (b - 1) * L))
        acc = lane_load(co, g0 * L) * lane_load(R, o + ir * L)
        if a == ir:
            acc = lane_load(co, C_QR * L) + acc
        for j in range(1, q):
            acc = acc + lane_load(co, (g0 + j) * L) * lane_load(R, o + (ir + j) * L)
        lane_store(Pn, w + ir * L, acc)
        for b in range(ir + 1, n):
            lane_store(Pn, w + b * L, lane_load(R, o + (b - 1) * L))
    # x; every row of predict's x starts from kappa (0 off the rho_s,k row): kept, so x never holds a -0
    zero = lane_splat(0.0)
    x1 = lane_load(x, L)
    x2 = lane_load(x, 2 * L)
    lane_store(xn, 0, ((zero + lane_load(x, 0)) + f01 * x1) + f02 * x2)
    lane_store(xn, L, (zero + x1) + f12 * x2)
    lane_store(xn, 2 * L, zero + x2)
    acc = zero + lane_load(co, b0 * L) * lane_load(x, 3 * L)
    for j in range(1, p):
        acc = acc + lane_load(co, (b0 + j) * L) * lane_load(x, (3 + j) * L)
    lane_store(xn, 3 * L, acc)
    acc = lane_load(co, C_KAP * L) + lane_load(co, g0 * L) * lane_load(x, ir * L)
    for j in range(1, q):
        acc = acc + lane_load(co, (g0 + j) * L) * lane_load(x, (ir + j) * L)
    lane_store(xn, ir * L, acc)
    for a in range(4, ir):
        lane_store(xn, a * L, zero + lane_load(x, (a - 1) * L))
    for a in range(ir + 1, n):
        lane_store(xn, a * L, zero + lane_load(x, (a - 1) * L))


def ar_predict_flops(p: int, q: int) -> int:
    """Floating-point additions and multiplications of one :func:`ar_predict` per trial, counted from its code."""
    n = 3 + p + q
    g = n * (4 + 2 + (2 * p - 1) + (2 * q - 1))  # rows 0, 1, 3, ir of F P, per column
    pn = 3 * (5 + 3 + 1) + (n - 3) * (4 + 2)  # columns 0-2 (with Q_d on rows 0-2)
    pn += n * ((2 * p - 1) + (2 * q - 1)) + 2  # columns 3 and ir (+ Q[3, 3], Q[ir, ir])
    xs = 5 + 3 + 1 + 2 * p + 2 * q + (p - 1) + (q - 1)  # x, every row from kappa or 0
    return g + pn + xs


@njit(cache=True)
def iq_update(x, P, ph0, ph1, A, ir, r, yr, yi):
    """EKF update on z = [I, Q] (eqs. 13-14), R = r I_2, on lanes.

    H has non-zero entries only in the columns of theta_d (0), theta_s,k (3)
    and rho_s,k (``ir``), so ``P H^T`` (``ph0``, ``ph1``) is two weighted
    column sums and the 2 x 2 innovation covariance is inverted in closed form;
    ``x += K e``, ``P -= K (P H^T)^T`` (every entry, both triangles).
    ``x`` (n, LANES), ``P`` (n, n, LANES), ``r``/``yr``/``yi`` (LANES,);
    work arrays ``ph0``, ``ph1`` (n, LANES).  A zero innovation determinant on
    any lane raises ZeroDivisionError (:func:`lanes_any_zero`), as numba's scalar division does.
    """
    L = LANES
    n = x.shape[0]
    if (not 3 < ir < n or x.shape != (n, L) or P.shape != (n, n, L) or ph0.shape != (n, L) or ph1.shape != (n, L)
            or r.shape != (L,) or yr.shape != (L,) or yi.shape != (L,)):
        raise ValueError("iq_update: arrays must be x, ph0, ph1 (n, LANES), P (n, n, LANES), r, yr, yi (LANES,), 3 < ir < n")
    # the linearisation point theta_d + theta_s (trig.sincos on the lane vector)
    rho = lane_load(x, ir * L)
    s_, c_ = trig.sincos(lane_load(x, 0) + lane_load(x, 3 * L))
    a0 = -A * rho * s_
    a1 = A * rho * c_
    b0 = A * c_
    b1 = A * s_
    e0 = lane_load(yr, 0) - A * rho * c_
    e1 = lane_load(yi, 0) - A * rho * s_
    for a in range(n):
        o = a * n * L
        u = lane_load(P, o) + lane_load(P, o + 3 * L)
        v = lane_load(P, o + ir * L)
        lane_store(ph0, a * L, a0 * u + b0 * v)
        lane_store(ph1, a * L, a1 * u + b1 * v)
    hu0 = lane_load(ph0, 0) + lane_load(ph0, 3 * L)
    hu1 = lane_load(ph1, 0) + lane_load(ph1, 3 * L)
    rr = lane_load(r, 0)
    s00 = a0 * hu0 + b0 * lane_load(ph0, ir * L) + rr
    s01 = a0 * hu1 + b0 * lane_load(ph1, ir * L)
    s11 = a1 * hu1 + b1 * lane_load(ph1, ir * L) + rr
    det = s00 * s11 - s01 * s01
    if lanes_any_zero(det):
        raise ZeroDivisionError("division by zero")
    i00 = s11 / det
    i01 = -s01 / det
    i11 = s00 / det
    for a in range(n):
        h0 = lane_load(ph0, a * L)
        h1 = lane_load(ph1, a * L)
        k0 = h0 * i00 + h1 * i01
        k1 = h0 * i01 + h1 * i11
        lane_store(x, a * L, lane_load(x, a * L) + (k0 * e0 + k1 * e1))
        o = a * n * L
        for b in range(n):
            lane_store(P, o + b * L, lane_load(P, o + b * L) - (k0 * lane_load(ph0, b * L) + k1 * lane_load(ph1, b * L)))


def iq_update_flops(n: int) -> int:
    """Floating-point operations of one :func:`iq_update` per trial, counted from its code (3 of them
    divisions), :func:`.trig.sincos` included (:data:`.trig.SINCOS_OPS`)."""
    point = 1 + trig.SINCOS_OPS + 3 + 2 + 1 + 1 + 3 + 3  # th, sin and cos, a0 (with -A), a1, b0, b1, e0, e1
    ph = 7 * n  # u, P H^T (two columns)
    s = 2 + 4 + 3 + 4 + 3 + 4  # hu0, hu1, s00, s01, s11, det, S^-1 (3 divisions, one negation)
    gain = 10 * n  # K (two columns) and x += K e
    cov = 4 * n * n  # P -= K (P H^T)^T, every entry
    return point + ph + s + gain + cov


@njit(cache=True)
def fold_mirror(x, P, ir):
    """(rho, theta_s) -> (-rho, theta_s + pi) on every lag; P -> J P J."""
    n = x.size
    for a in range(3, ir):
        x[a] += math.pi
    for a in range(ir, n):
        x[a] = -x[a]
        for b in range(ir):
            P[a, b] = -P[a, b]
            P[b, a] = -P[b, a]


@njit(cache=True)
def nearest_index(value, points):
    """Index of the point nearest to ``value`` (the first one on ties)."""
    best = 0
    for j in range(points.size):
        if abs(value - points[j]) < abs(value - points[best]):
            best = j
    return best


@njit(cache=True)
def nearest_index_lanes(value, points):
    """:func:`nearest_index` on every lane of ``value`` (Lanes): the index, as a float, of the nearest point (the first one on ties)."""
    best = lane_splat(0.0)
    best_d = abs(value - points[0])
    for j in range(1, points.size):
        d = abs(value - points[j])
        best = lane_where_less(d, best_d, j, best)
        best_d = lane_where_less(d, best_d, d, best_d)
    return best
