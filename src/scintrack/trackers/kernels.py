"""Compiled (numba) time loops of the trackers.

Each kernel runs the same recursion as the vectorised numpy reference in the
tracker's module (``run_numpy``), one trial after the other, so a trial's
result never depends on the batch it is in.  ``tests/test_trackers.py`` checks
kernel against reference; ``benchmarks/bench_trackers.py`` measures both.

Why numba: the vectorised numpy filters ran at 0.16-0.32 million
filter-epochs per second for the AEKF-AR (per-epoch Python and small-array
overhead), well short of the 1 M/s the 500 x 500 s cycle-slip experiment
needs to finish in minutes.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _wrap_angle(r_re, r_im):
    return math.atan2(r_im, r_re)


@njit(cache=True)
def atan_variance_scalar(cn0_hz, ts):
    x = max(2.0 * cn0_hz * ts, 1e-6)
    return (math.exp(-0.8 * math.sqrt(x)) + 1.0) * math.erf(0.4 * x) / x


@njit(cache=True)
def _m2m4_split(m2, m4, floor_fraction):
    pd = math.sqrt(max(2.0 * m2 * m2 - m4, (floor_fraction * m2) ** 2))
    pd = min(pd, (1.0 - floor_fraction) * m2)
    return pd, m2 - pd


@njit(cache=True)
def _window_push(b1, b2, pos, s1, s2, count, v1, v2):
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


def nonzeros(F: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Non-zero entries of a stack of transition matrices (S, n, n), padded.

    F is block-diagonal with companion blocks, so ~16 of its 81 entries are
    non-zero; the predict step loops over those only.
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
def _predict(x, P, xp, FP, Q, kap, rows, cols, vals, count, use_kap):
    """x <- F x (+ kappa), P <- F P F^T + Q with F given by its non-zeros."""
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
def pll_kernel(y, phase0, v0, w0_state, ts, bandwidth_hz):
    n, k = y.shape
    w0 = bandwidth_hz / 0.7845
    a3, b3 = 1.1, 2.4
    out = np.empty((n, k))
    for t in range(n):
        phase, v, w = phase0[t], v0[t], w0_state[t]
        for i in range(k):
            out[t, i] = phase
            c, s = math.cos(phase), math.sin(phase)
            yr, yi = y[t, i].real, y[t, i].imag
            e = math.atan2(yi * c - yr * s, yr * c + yi * s)
            w_new = w + ts * w0**3 * e
            v_new = v + ts * (0.5 * (w_new + w) + a3 * w0**2 * e)
            f = 0.5 * (v_new + v) + b3 * w0 * e
            w, v = w_new, v_new
            phase = phase + f * ts
    return out


@njit(cache=True)
def kf_kernel(y, x0, P0, F, Q, H, adaptive, r_fixed, window, prior_signal, prior_noise, ts, min_epochs, floor_fraction, nz_rows, nz_cols, nz_vals, nz_count):
    n_tr, k = y.shape
    n = F.shape[0]
    rows, cols, vals, nnz = nz_rows[0], nz_cols[0], nz_vals[0], nz_count[0]
    kap = np.zeros(n)
    out = np.empty((n_tr, k))
    r_out = np.empty((n_tr, k)) if adaptive else np.empty((0, 0))
    buf2 = np.zeros(window)
    buf4 = np.zeros(window)
    x = np.empty(n)
    xp = np.empty(n)
    P = np.empty((n, n))
    FP = np.empty((n, n))
    PH = np.empty(n)
    for t in range(n_tr):
        x[:] = x0[t]
        P[:, :] = P0
        buf2[:] = 0.0
        buf4[:] = 0.0
        s2 = 0.0
        s4 = 0.0
        count = 0
        pos = 0
        for i in range(k):
            if i > 0:
                _predict(x, P, xp, FP, Q, kap, rows, cols, vals, nnz, False)
            phase = 0.0
            for a in range(n):
                phase += H[a] * x[a]
            c_, s_ = math.cos(phase), math.sin(phase)
            yr, yi = y[t, i].real, y[t, i].imag
            nu = math.atan2(yi * c_ - yr * s_, yr * c_ + yi * s_)
            if adaptive:
                p2 = yr * yr + yi * yi
                pos, s2, s4, count = _window_push(buf2, buf4, pos, s2, s4, count, p2, p2 * p2)
                if count < min_epochs:
                    sig, noi = prior_signal, prior_noise
                else:
                    sig, noi = _m2m4_split(s2 / count, s4 / count, floor_fraction)
                R = atan_variance_scalar(sig / (noi * ts), ts)
                r_out[t, i] = R
            else:
                R = r_fixed
            S = R
            for a in range(n):
                acc = 0.0
                for b in range(n):
                    acc += P[a, b] * H[b]
                PH[a] = acc
                S += H[a] * acc
            for a in range(n):
                x[a] += PH[a] / S * nu
            for a in range(n):
                ka = PH[a] / S
                for b in range(n):
                    P[a, b] -= ka * PH[b]
            out[t, i] = x[0]
    return out, r_out


@njit(cache=True)
def aekf_kernel(
    y, x0, p0, F_tab, Q_tab, kap_tab, s4_points, adaptive, initial_set, A, nominal_noise,
    noise_window, s4_window, s4_min_epochs, adapt_hold, ir, record, floor_fraction, nz_rows, nz_cols, nz_vals, nz_count,
    fold_mirror=False,
):
    n_tr, k = y.shape
    n = F_tab.shape[1]
    out = np.empty((n_tr, k))
    if record:
        rec_ts = np.empty((n_tr, k))
        rec_rho = np.empty((n_tr, k))
        rec_s4 = np.empty((n_tr, k))
        rec_set = np.empty((n_tr, k))
    else:
        rec_ts = np.empty((0, 0))
        rec_rho = np.empty((0, 0))
        rec_s4 = np.empty((0, 0))
        rec_set = np.empty((0, 0))
    nb2 = np.zeros(noise_window)
    nb4 = np.zeros(noise_window)
    sb1 = np.zeros(s4_window)
    sb2 = np.zeros(s4_window)
    x = np.empty(n)
    xp = np.empty(n)
    P = np.empty((n, n))
    FP = np.empty((n, n))
    ph0 = np.empty(n)
    ph1 = np.empty(n)
    for t in range(n_tr):
        x[:] = x0[t]
        P[:, :] = 0.0
        for a in range(n):
            P[a, a] = p0[a]
        nb2[:] = 0.0
        nb4[:] = 0.0
        sb1[:] = 0.0
        sb2[:] = 0.0
        ns2 = 0.0
        ns4 = 0.0
        ncount = 0
        npos = 0
        ss1 = 0.0
        ss2 = 0.0
        scount = 0
        spos = 0
        idx = initial_set
        candidate = initial_set
        held = 0
        s4_hat = s4_points[initial_set]
        for i in range(k):
            if i > 0:
                _predict(x, P, xp, FP, Q_tab[idx], kap_tab[idx], nz_rows[idx], nz_cols[idx], nz_vals[idx], nz_count[idx], True)
            yr, yi = y[t, i].real, y[t, i].imag
            p2 = yr * yr + yi * yi
            # M2M4 noise power over the last noise_window epochs
            npos, ns2, ns4, ncount = _window_push(nb2, nb4, npos, ns2, ns4, ncount, p2, p2 * p2)
            if ncount < 10:
                s2 = nominal_noise
            else:
                _, s2 = _m2m4_split(ns2 / ncount, ns4 / ncount, floor_fraction)
            r = 0.5 * s2
            th = x[0] + x[3]
            rho = x[ir]
            c_, s_ = math.cos(th), math.sin(th)
            a0, a1 = -A * rho * s_, A * rho * c_
            b0, b1 = A * c_, A * s_
            for a in range(n):
                u = P[a, 0] + P[a, 3]
                v = P[a, ir]
                ph0[a] = a0 * u + b0 * v
                ph1[a] = a1 * u + b1 * v
            hu0 = ph0[0] + ph0[3]
            hu1 = ph1[0] + ph1[3]
            s00 = a0 * hu0 + b0 * ph0[ir] + r
            s01 = a0 * hu1 + b0 * ph1[ir]
            s11 = a1 * hu1 + b1 * ph1[ir] + r
            det = s00 * s11 - s01 * s01
            i00, i01, i11 = s11 / det, -s01 / det, s00 / det
            e0 = yr - A * rho * c_
            e1 = yi - A * rho * s_
            for a in range(n):
                k0 = ph0[a] * i00 + ph1[a] * i01
                k1 = ph0[a] * i01 + ph1[a] * i11
                x[a] += k0 * e0 + k1 * e1
                for b in range(n):
                    P[a, b] -= k0 * ph0[b] + k1 * ph1[b]
            if fold_mirror and x[ir] < 0.0:
                # (rho, theta_s) -> (-rho, theta_s + pi): same I/Q prediction; P -> J P J
                for a in range(3, ir):
                    x[a] += math.pi
                for a in range(ir, n):
                    x[a] = -x[a]
                    for b in range(ir):
                        P[a, b] = -P[a, b]
                        P[b, a] = -P[b, a]
            if i % 64 == 63:
                for a in range(n):
                    for b in range(a + 1, n):
                        m = 0.5 * (P[a, b] + P[b, a])
                        P[a, b] = m
                        P[b, a] = m
            if adaptive:
                spos, ss1, ss2, scount = _window_push(sb1, sb2, spos, ss1, ss2, scount, p2, p2 * p2)
                if scount >= s4_min_epochs:
                    mean = ss1 / scount
                    var = max(ss2 / scount - mean * mean, 0.0)
                    sig = max(mean - s2, 1e-12)
                    s4sq = (var - 2.0 * sig * s2 - s2 * s2) / (sig * sig)
                    s4_hat = math.sqrt(max(s4sq, 0.0))
                best = 0
                for j in range(s4_points.size):
                    if abs(s4_hat - s4_points[j]) < abs(s4_hat - s4_points[best]):
                        best = j
                held = held + 1 if best == candidate else 0
                candidate = best
                if held >= adapt_hold:
                    idx = candidate
            out[t, i] = x[0]
            if record:
                rec_ts[t, i] = x[3]
                rec_rho[t, i] = x[ir]
                rec_s4[t, i] = s4_hat
                rec_set[t, i] = idx
    return out, rec_ts, rec_rho, rec_s4, rec_set


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
