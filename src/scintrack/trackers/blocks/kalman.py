"""Kalman predict and measurement-update steps, on one trial and on lanes.

Vila-Valls et al. 2018 (Sec. IV-V) and Susi et al. 2014:

* eqs. (8), (11) prediction ``x <- F x (+ kappa)``, ``P <- F P F^T + Q`` with
  F given by its non-zeros: :func:`predict` (:func:`nonzeros` lists them), on
  ``LANES`` trials at once without kappa: :func:`sparse_predict_lanes`;
* scalar measurement update on lanes (discriminator KFs,
  ``H = [1, 0, 0, (1, 0..)]``, Sec. V-A): :func:`scalar_update_lanes` (its
  ``P H^T`` and ``S``: :func:`innovation_terms_lanes`); with a weighted gain
  and the Joseph covariance (Susi 2014, eq. 12): :func:`weighted_scalar_update_lanes`;
* the (phase, frequency) white-noise Q of Susi's eqs. (3)-(8):
  :func:`phase_frequency_q`.

The lane forms apply every operation to every lane in the same order and with
the same operands (the zero entries of H and the unit entries of F included:
an inf or NaN meets them alike), and no lane reads another.  An exact-zero
innovation variance on any lane raises ZeroDivisionError
(:func:`scintrack.simd.lanes.lanes_any_zero`), as numba's scalar division does.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...simd import LANES
from ...simd.lanes import lane_load, lane_splat, lane_store, lanes_any_zero

__all__ = [
    "innovation_terms_lanes",
    "nonzeros",
    "phase_frequency_q",
    "predict",
    "scalar_update_lanes",
    "sparse_predict_lanes",
    "weighted_scalar_update_lanes",
]

def nonzeros(F: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Non-zero entries of a stack of transition matrices (S, n, n), padded.

    F is block-diagonal with companion blocks, so ~16 of its 81 entries are
    non-zero; :func:`predict` loops over those only.
    """
    F = F if F.ndim == 3 else F[None]
    counts = np.array([np.count_nonzero(f) for f in F], dtype=np.int64)
    m = int(counts.max()) if counts.size else 0
    rows = np.zeros((F.shape[0], m), dtype=np.int64)
    cols = np.zeros((F.shape[0], m), dtype=np.int64)
    vals = np.zeros((F.shape[0], m))
    for j, f in enumerate(F):
        r, c = np.nonzero(f)
        rows[j, : r.size], cols[j, : r.size], vals[j, : r.size] = r, c, f[r, c]
    return rows, cols, vals, counts


@njit(cache=True)
def predict(x, P, xp, FP, Q, kap, rows, cols, vals, count, use_kap):
    """x <- F x (+ kappa), P <- F P F^T + Q with F given by its non-zeros (eqs. 8, 11)."""
    n = x.size
    for a in range(n):
        xp[a] = kap[a] if use_kap else 0.0
    FP[:, :] = 0.0
    for m in range(count):
        a, c, v = rows[m], cols[m], vals[m]
        xp[a] += v * x[c]
        for b in range(n):
            FP[a, b] += v * P[c, b]
    x[:] = xp
    P[:, :] = Q
    for m in range(count):
        b, c, v = rows[m], cols[m], vals[m]
        for a in range(n):
            P[a, b] += v * FP[a, c]


@njit(cache=True)
def phase_frequency_q(s_phi, s_f, ts, out):
    """Discrete Q of the state [phase (rad), frequency (Hz), rate] from white noises on
    the phase (PSD ``s_phi``, rad^2/s) and on the frequency (``s_f``, Hz^2/s) of the
    continuous model ``dphi/dt = 2 pi f + w_phi``, ``df/dt = a + w_f`` (Susi eqs. 3-4):

    ``Q00 = s_phi T + (2 pi)^2 s_f T^3 / 3``, ``Q01 = 2 pi s_f T^2 / 2``, ``Q11 = s_f T``
    (added to ``out``, a 3 x 3 array).  The same matrix as
    :func:`scintrack.models.clock.process_noise` for a clock, in (rad, Hz).
    """
    c = 2.0 * math.pi
    out[0, 0] += s_phi * ts + c * c * s_f * ts**3 / 3.0
    out[0, 1] += c * s_f * ts**2 / 2.0
    out[1, 0] += c * s_f * ts**2 / 2.0
    out[1, 1] += s_f * ts


# --- on lanes ---------------------------------------------------------------------


@njit(cache=True)
def sparse_predict_lanes(x, P, xn, FP, Q, rows, cols, vals, count):
    """:func:`predict` without kappa on lanes: ``x <- F x``, ``P <- F P F^T + Q``, F given by its non-zeros.

    ``x`` (n, LANES) and ``P`` (n, n, LANES) are updated in place; ``Q``
    (n, n, LANES): each lane's process noise; ``rows``, ``cols``, ``vals``,
    ``count``: the non-zeros of F (:func:`nonzeros`, one set, common to the
    lanes); work arrays ``xn`` (n, LANES), ``FP`` (n, n, LANES).  Per lane the
    sums of :func:`predict` (``use_kap`` False): each x entry from 0.0, F P from
    0.0, P from Q, accumulated over the same non-zeros in the same order (unit
    entries of F multiplied, as there), so x and P are the scalar block's bit for bit.
    """
    L = LANES
    n = x.shape[0]
    if x.shape != (n, L) or xn.shape != (n, L) or P.shape != (n, n, L) or FP.shape != (n, n, L) or Q.shape != (n, n, L):
        raise ValueError("sparse_predict_lanes: arrays must be x, xn (n, LANES), P, FP, Q (n, n, LANES)")
    zero = lane_splat(0.0)
    for a in range(n):
        lane_store(xn, a * L, zero)
    for e in range(n * n):
        lane_store(FP, e * L, zero)
    for m in range(count):
        a, c, v = rows[m], cols[m], vals[m]
        lane_store(xn, a * L, lane_load(xn, a * L) + v * lane_load(x, c * L))
        for b in range(n):
            o = (a * n + b) * L
            lane_store(FP, o, lane_load(FP, o) + v * lane_load(P, (c * n + b) * L))
    for a in range(n):
        lane_store(x, a * L, lane_load(xn, a * L))
    for e in range(n * n):
        lane_store(P, e * L, lane_load(Q, e * L))
    for m in range(count):
        b, c, v = rows[m], cols[m], vals[m]
        for a in range(n):
            o = (a * n + b) * L
            lane_store(P, o, lane_load(P, o) + v * lane_load(FP, (a * n + c) * L))


@njit(cache=True)
def innovation_terms_lanes(P, H, R, PH):
    """``PH = P H^T`` (n, LANES) written and the innovation variance ``S = H P H^T + R`` of a scalar measurement
    returned (Lanes).

    ``P`` (n, n, LANES), ``H`` (n,) common to the lanes, ``R`` (LANES,)."""
    L = LANES
    n = PH.shape[0]
    if P.shape != (n, n, L) or PH.shape != (n, L) or H.shape != (n,) or R.shape != (L,):
        raise ValueError("innovation_terms_lanes: arrays must be P (n, n, LANES), H (n,), R (LANES,), PH (n, LANES)")
    S = lane_load(R, 0)
    for a in range(n):
        acc = lane_splat(0.0)
        for b in range(n):
            acc = acc + lane_load(P, (a * n + b) * L) * H[b]
        lane_store(PH, a * L, acc)
        S = S + H[a] * acc
    return S


@njit(cache=True)
def scalar_update_lanes(x, P, PH, H, R, nu):
    """Scalar measurement on lanes: S = H P H^T + R, K = P H^T / S, x += K nu, P -= K (P H^T)^T.

    ``x`` (n, LANES), ``P`` (n, n, LANES) in place; ``H`` (n,) common; ``R``,
    ``nu`` (LANES,); work array ``PH`` (n, LANES).  An exact-zero S on any lane
    raises ZeroDivisionError, as the scalar division does."""
    L = LANES
    n = x.shape[0]
    if x.shape != (n, L) or nu.shape != (L,):
        raise ValueError("scalar_update_lanes: arrays must be x (n, LANES), nu (LANES,)")
    S = innovation_terms_lanes(P, H, R, PH)
    if lanes_any_zero(S):
        raise ZeroDivisionError("division by zero")
    e = lane_load(nu, 0)
    for a in range(n):
        lane_store(x, a * L, lane_load(x, a * L) + lane_load(PH, a * L) / S * e)
    for a in range(n):
        ka = lane_load(PH, a * L) / S
        o = a * n * L
        for b in range(n):
            lane_store(P, o + b * L, lane_load(P, o + b * L) - ka * lane_load(PH, b * L))


@njit(cache=True)
def weighted_scalar_update_lanes(x, P, PH, H, R, nu, w):
    """Scalar update with the gain weighted by ``w`` (Susi eq. 12, ``K' = w K``), on lanes.

    ``S = H P H^T + R``, ``K = P H^T / S``, ``x += w K nu``, and the Joseph form
    ``P = (I - w K H) P (I - w K H)^T + w^2 K R K^T``, which for a scalar
    measurement is ``P -= (2 w - w^2) (P H^T)(P H^T)^T / S`` (the covariance of
    the weighted, suboptimal filter; ``w = 1`` is the ordinary update).
    ``w`` (LANES,), otherwise the arrays of :func:`scalar_update_lanes`.  An
    exact-zero S on any lane raises ZeroDivisionError."""
    L = LANES
    n = x.shape[0]
    if x.shape != (n, L) or nu.shape != (L,) or w.shape != (L,):
        raise ValueError("weighted_scalar_update_lanes: arrays must be x (n, LANES), nu, w (LANES,)")
    S = innovation_terms_lanes(P, H, R, PH)
    if lanes_any_zero(S):
        raise ZeroDivisionError("division by zero")
    wv = lane_load(w, 0)
    g = (2.0 * wv - wv * wv) / S
    e = lane_load(nu, 0)
    for a in range(n):
        lane_store(x, a * L, lane_load(x, a * L) + wv * lane_load(PH, a * L) / S * e)
    for a in range(n):
        o = a * n * L
        gpa = g * lane_load(PH, a * L)
        for b in range(n):
            lane_store(P, o + b * L, lane_load(P, o + b * L) - gpa * lane_load(PH, b * L))
