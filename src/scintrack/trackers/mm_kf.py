"""Two-mode multiple-model (MM) EKF carrier tracker through data bits (Zhao et al.); type ``mm_kf``.

Paper: Zhao, Khanafseh & Pervan, "MM Kalman filter ... wideband jamming",
Sec. II (eqs. 2-9) and Sec. II.3 "MM Algorithm"; reference notes
``gps-lnav-mm.md`` §4.

Model.  Observations ``y_k = I_k + j Q_k`` at period ``T`` (``ts``; 20 ms for
bit-synchronous GPS sums):

* eqs. (6)-(7): ``I_k = d_k A_k cos(phi_k) + v_I``, ``Q_k = d_k A_k sin(phi_k) + v_Q``,
  ``v ~ N(0, sigma_v^2 I_2)``, ``d_k = +-1`` the data level;
* eq. (2): state ``x = [A, phi (rad), f (Hz)]``,
  ``F = [[1, 0, 0], [0, 1, 2 pi T], [0, 0, 1]]``;
* eq. (3): ``W = blkdiag(delta^2, Q_clk)`` with the clock block of
  :mod:`scintrack.models.clock` for the configured oscillator preset (default
  ``zhao_tcxo``), computed in (cycles, Hz) and scaled by ``diag(2 pi, 1)`` on
  both sides to (rad, Hz).  ``q_form: exact`` (default) is the exact discrete
  two-state Q (:func:`~scintrack.models.clock.process_noise`, the model the
  jammed dataset's truth is drawn from); ``q_form: zhao_eq3`` is eq. (3) as
  printed (:func:`~scintrack.models.clock.process_noise_zhao_eq3`; its
  frequency entry ``S_f / T + 4/3 S_g T`` is ~4e4 times the exact one at
  20 ms for the Zhao TCXO, i.e. a much wider frequency random walk).
  ``q_freq_scale`` s multiplies the clock block as ``D Q_clk D`` with
  ``D = diag(1, sqrt(s))``: the frequency variance times s, the phase-frequency
  covariance times sqrt(s), so Q stays positive semi-definite and the
  correlation coefficient is unchanged (a robustness knob, not in the paper).
* eq. (9): ``R = sigma_v^2 I_2``.  ``r: m2m4`` (default): ``sigma_v^2 = Pn / 2``
  with ``Pn`` the M2M4 complex noise power (:func:`.blocks.m2m4_split`) over
  the last ``m2m4_window`` observations including the current one
  (:func:`.blocks.window_push`).  Until the window has filled, the estimate of
  the first window is used (a start-up look-ahead of one window, as an
  acquisition uses the first samples; the sliding estimate equals it when the
  window first fills).  Default window 100 epochs (2 s at 20 ms): at
  15 dB-Hz a 50-epoch M2M4 signal estimate hits its floor in ~10 % of the
  trials, 100 epochs keep the start-up amplitude usable while following a
  jammer's onset within 2 s.  ``r: <number>``: a known ``sigma_v^2`` per component,
  in prompt units squared (eq. 9 for unit amplitude: ``1 / (2 T C/N0)``).

MM algorithm.  Bits are independent with prior ``pi_k(+1)`` =
``TrackInit.bit_prior`` (None: pilot, ``pi = 1``), so the IMM transition
matrix has identical rows, mixing returns the merged estimate and the IMM is
GPB1 (notes §4.1): per epoch one prediction, two EKF updates linearised about
the same prediction, ``h_d(x) = d A [cos phi, sin phi]``, ``H_- = -H_+``, so
``S_+ = S_- = S`` and ``K_- = -K_+``.  The mode posterior
``mu_d ∝ pi_d N(y - h_d; 0, S)`` is computed in the log domain with a
log-sum-exp (the common ``-log det(2 pi S) / 2`` cancels and is dropped in the
kernel; the reference keeps it), so it cannot underflow at any C/N0, and
priors of exactly 0 or 1 (log prior -inf, the paper's "prior probability 1"
for predicted bits) give the d-known EKF.  The posterior log-odds are
``log(pi_+/pi_-) + 2 zhat_+^T S^-1 y``.  The modes are merged by moment
matching, ``x = sum mu_d x_d``, ``P = P_post + mu_+ mu_- (x_+ - x_-)(x_+ - x_-)^T``
(the spread-of-means term), and the merged pair is the next prior.

Choices the paper leaves open, and why:

* units: phase in rad and frequency in Hz (F carries the 2 pi); the Zhao h's
  are phase-PSD coefficients in cycles^2 (:mod:`scintrack.models.clock`);
* amplitude variances (``p0_diag[0]`` and ``amplitude_q`` = delta^2) are
  relative to ``amplitude0^2``: the prompts' scale is arbitrary (unit-noise
  AGC, unit-amplitude simulation), and so the filter is invariant to a
  rescaling of ``y`` (tested).  ``amplitude_q`` defaults to 0 (the paper's
  delta^2 ~ 0); raise it for AGC-normalised prompts, whose amplitude drops
  when a jammer starts;
* ``amplitude0``: the spec value, else ``sqrt`` of the M2M4 signal power of
  the first window (floored at 1e-3 m2, so > 0: with unknown bits ``A = 0``
  is a fixed point of the merged mean, by the (d, A) -> (-d, -A) symmetry);
* initial phase and frequency: ``TrackInit.phase`` and ``doppler_hz`` (the
  residual after the NCO); ``rate_hz_s`` is ignored (the clock model has no
  rate state: static receiver, geometric Doppler removed, paper Sec. II.1);
  default ``p0_diag = (0.01, 0.1 rad^2, 1 Hz^2)``;
* the output phase is the filtered (posterior) merged phase at each epoch,
  unwrapped (the state is never wrapped); with unknown bits it is defined up
  to the (d, phi) = (-d, phi + pi) ambiguity, resolved by the initial phase;
* the sinc loss and the phase averaging over one integration are not in eqs.
  (6)-(7) and are not modelled;
* the covariance update is ``P - K (P H^T)^T``, symmetrised every epoch
  (:func:`.blocks.symmetrise`) as a numerical safeguard;
* extras: ``frequency_hz``, ``amplitude``, ``p_plus`` (posterior probability of
  d = +1), ``log_odds`` (its log-odds, the soft bit for a decoder; +-inf for
  known bits) and ``cn0_dbhz = 10 log10(A^2 / (2 sigma_v^2 T))``
  (:func:`.blocks.cn0_from_powers`); ``cov_fail_epoch`` (trials,): the first
  epoch whose (phase, frequency) covariance fails :func:`.blocks.covariance_ok`
  (-1 none; the amplitude variance may legitimately reach 0 with ``amplitude_q = 0``).

Lanes: :func:`mm_kf_loop` runs ``blocks.LANES`` (32) trials side by side, one
SIMD vector per state entry (:func:`two_mode_iq_update_lanes`): the filter's
epochs form one chain of dependent divisions, exponentials and products, and
32 independent trials fill the core's latencies.  No operation is fused or
reassociated (no fast-math) and no lane reads another, so a trial's result
does not depend on its batch.  Where one mode is impossible (a pilot, or a
bit known to be +1 or -1) the mode weights are their exact values, 1 and 0,
without the log-sum-exp's exponentials.  Tests
(``tests/test_lane_kernels.py``): the loop against :meth:`MMKF.reference`,
the same bits in batches of 1, 31, 32, 33 and 40 trials, from epoch 0 and
resumed, NaN and inf prompts.  :meth:`MMKF.resume` restarts trials from the
first changed bit prior (the IODE-check receiver's fixed-point iterations).

Config: ``{type: mm_kf, clock: zhao_tcxo, q_form: exact, r: m2m4, m2m4_window: 100}``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from ..estimators.cn0 import M2M4_FLOOR, StreamingM2M4, cn0_from_powers, m2m4
from ..models import clock as clock_models
from ..simd.lanes import lane_load, lane_store
from . import blocks, trig
from .base import Tracker, TrackerContext, TrackInit, TrackOutput
from .registry import register

Q_FORMS = ("exact", "zhao_eq3")
DEFAULT_P0 = (0.01, 0.1, 1.0)
DEFAULT_WINDOW = 100


class MmParams(NamedTuple):
    """Everything :func:`mm_kf_kernel` needs besides the prompts."""

    x0: np.ndarray  # (trials, 3) [A, phi rad, f Hz]
    P0: np.ndarray  # (trials, 3, 3)
    Q: np.ndarray  # (trials, 3, 3) (amplitude entry relative to amplitude0^2)
    log_pp: np.ndarray  # (trials, epochs) log pi(d = +1)
    log_pm: np.ndarray  # (trials, epochs) log pi(d = -1)
    adaptive: bool  # R from the sliding M2M4 noise power, else r_fixed
    r_fixed: float  # sigma_v^2 per component
    window: int  # M2M4 window [epochs]
    prior_noise: np.ndarray  # (trials,) M2M4 complex noise power of the first window
    ts: float
    floor_fraction: float
    nz_rows: np.ndarray  # non-zeros of F (blocks.nonzeros)
    nz_cols: np.ndarray
    nz_vals: np.ndarray
    nz_count: np.ndarray


@njit(cache=True)
def log_sum_exp2(a, b):
    """``log(exp(a) + exp(b))`` without overflow or underflow; -inf if both are -inf."""
    m = max(a, b)
    if m == -np.inf:
        return m
    return m + math.log(math.exp(a - m) + math.exp(b - m))


#: the posterior covariance entries kept per epoch for :meth:`MMKF.resume` (upper triangle, row by row)
COV_ENTRIES = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
#: the per-epoch outputs, in :func:`mm_kf_loop`'s argument order, and their keys in ``TrackOutput`` (theta: ``theta_d``)
OUTPUTS = {"theta": "theta_d", "freq": "frequency_hz", "amp": "amplitude", "p_plus": "p_plus", "log_odds": "log_odds", "cn0": "cn0_dbhz"}


@njit(cache=True)
def mm_kf_kernel(y, prm, keep_covariance=False):
    """The filter over every trial from epoch 0: (theta, freq, amp, p_plus, log_odds, cn0_db, cov, cov_fail),
    ``cov`` the posterior covariances (:func:`mm_kf_loop`) if ``keep_covariance``, else without epochs."""
    n_tr, k = y.shape
    theta, freq, amp = np.empty((n_tr, k)), np.empty((n_tr, k)), np.empty((n_tr, k))
    p_plus, log_odds, cn0_db = np.empty((n_tr, k)), np.empty((n_tr, k)), np.empty((n_tr, k))
    cov = np.empty((n_tr, k if keep_covariance else 0, 6))
    cov_fail = np.full(n_tr, -1, dtype=np.int64)
    mm_kf_loop(y, prm, np.zeros(n_tr, dtype=np.int64), theta, freq, amp, p_plus, log_odds, cn0_db, cov, cov_fail)
    return theta, freq, amp, p_plus, log_odds, cn0_db, cov, cov_fail


@njit(cache=True)
def two_mode_iq_update_lanes(x, P, ph0, ph1, k0, k1, dx, cs, sn, r, yr, yi, lpp, lpm, mu_p, log_odds):
    """GPB1 step on z = [I, Q] for d = +-1 from one prediction, ``blocks.LANES`` trials at once (SIMD over trials).

    ``H_+ = [[c, -A s, 0], [s, A c, 0]]`` at the predicted (A, phi), ``H_- = -H_+``: one S and one gain
    ``K`` (``K_- = -K``); ``x_+ = x + K (y - zhat)``, ``x_- = x - K (y + zhat)``; mode weights in logs
    (:func:`log_sum_exp2`); moment-matched merge ``x = mu_+ x_+ + mu_- x_-``,
    ``P = P - K (P H^T)^T + mu_+ mu_- (x_+ - x_-)(x_+ - x_-)^T``.

    ``x`` (3, LANES), ``P`` (3, 3, LANES) in place; ``r``, ``yr``, ``yi``, the log priors ``lpp``, ``lpm``
    (LANES,); outputs ``mu_p`` (mu_+) and ``log_odds`` (LANES,); work arrays ``ph0``, ``ph1``, ``k0``, ``k1``,
    ``dx`` (3, LANES) and ``cs``, ``sn`` (LANES,).  IEEE arithmetic on lane vectors (no contraction),
    :func:`.trig.sincos` on the lane vector; the libm calls (exp, log) and the log-sum-exp's branch are
    made per lane.  An exact-zero ``det S`` on any lane raises ZeroDivisionError, as numba's scalar
    division does.
    """
    L = blocks.LANES
    A = lane_load(x, 0)
    s_, c_ = trig.sincos(lane_load(x, L))
    for a in range(3):
        pa0, pa1 = lane_load(P, (3 * a) * L), lane_load(P, (3 * a + 1) * L)
        lane_store(ph0, a * L, pa0 * c_ - pa1 * A * s_)
        lane_store(ph1, a * L, pa0 * s_ + pa1 * A * c_)
    p00, p01, p10, p11 = lane_load(ph0, 0), lane_load(ph0, L), lane_load(ph1, 0), lane_load(ph1, L)
    rv = lane_load(r, 0)
    s00 = c_ * p00 - A * s_ * p01 + rv
    s01 = c_ * p10 - A * s_ * p11
    s11 = s_ * p10 + A * c_ * p11 + rv
    det = s00 * s11 - s01 * s01
    if blocks.lanes_any_zero(det):
        raise ZeroDivisionError("division by zero")
    i00, i01, i11 = s11 / det, -s01 / det, s00 / det
    zr, zi = A * c_, A * s_
    vr, vi = lane_load(yr, 0), lane_load(yi, 0)
    pr, pi_ = vr - zr, vi - zi
    mr, mi = vr + zr, vi + zi
    lane_store(mu_p, 0, lane_load(lpp, 0) - 0.5 * (pr * (i00 * pr + i01 * pi_) + pi_ * (i01 * pr + i11 * pi_)))  # wp
    lane_store(log_odds, 0, lane_load(lpm, 0) - 0.5 * (mr * (i00 * mr + i01 * mi) + mi * (i01 * mr + i11 * mi)))  # wm
    for ln in range(L):  # mode weights per lane (libm, the -inf branch); cs, sn reused for mu_-, mu_+ mu_-
        wp, wm = mu_p[ln], log_odds[ln]
        if wm == -np.inf and math.isfinite(wp):
            # d = -1 impossible (a pilot, or a bit known to be +1): the values the general expressions give
            # exactly (log-sum-exp = wp + log(1 + 0) = wp + 0, exp(0) = 1, exp(-inf) = 0), without 4 exp + 1 log
            mu_p[ln], cs[ln], sn[ln] = 1.0, 0.0, 0.0
        elif wp == -np.inf and math.isfinite(wm):
            mu_p[ln], cs[ln], sn[ln] = 0.0, 1.0, 0.0
        else:
            lse = log_sum_exp2(wp, wm)
            mu_p[ln] = math.exp(wp - lse)
            cs[ln] = math.exp(wm - lse)
            sn[ln] = math.exp(wp + wm - 2.0 * lse)
        log_odds[ln] = wp - wm
    mp, mm, spread = lane_load(mu_p, 0), lane_load(cs, 0), lane_load(sn, 0)
    for a in range(3):
        q0, q1 = lane_load(ph0, a * L), lane_load(ph1, a * L)
        lane_store(k0, a * L, q0 * i00 + q1 * i01)
        lane_store(k1, a * L, q0 * i01 + q1 * i11)
    for a in range(3):
        xa, ka0, ka1 = lane_load(x, a * L), lane_load(k0, a * L), lane_load(k1, a * L)
        xp_a = xa + ka0 * pr + ka1 * pi_
        xm_a = xa - (ka0 * mr + ka1 * mi)
        lane_store(dx, a * L, xp_a - xm_a)
        lane_store(x, a * L, mp * xp_a + mm * xm_a)
    for a in range(3):
        sda, ka0, ka1 = spread * lane_load(dx, a * L), lane_load(k0, a * L), lane_load(k1, a * L)
        for b in range(3):
            o = (3 * a + b) * L
            lane_store(P, o, lane_load(P, o) + (sda * lane_load(dx, b * L) - (ka0 * lane_load(ph0, b * L) + ka1 * lane_load(ph1, b * L))))


@njit(cache=True)
def mm_kf_loop(y, prm, start, theta, freq, amp, p_plus, log_odds, cn0_db, cov, cov_fail):
    """The filter of trial ``t`` over epochs ``start[t] ..`` into the output arrays (trials, epochs),
    ``blocks.LANES`` trials at a time (trial on the last axis: SIMD over trials).

    ``start[t] = 0``: from ``prm.x0``, ``prm.P0``.  ``start[t] = s > 0``: from the posterior of epoch
    ``s - 1`` already in the outputs (state ``amp, theta, freq`` and covariance ``cov``), with the M2M4
    window pushed over epochs ``0 .. s-1`` (the same pushes, so the same sums): the rest of the trial
    then has the bits of a run from epoch 0, the filter being causal.  ``start[t] >= epochs``: nothing.
    ``cov`` (trials, epochs, 6) receives the posterior covariance (:data:`COV_ENTRIES`) of every epoch
    computed, or has no epochs (not kept).  ``cov_fail[t]`` must hold the trial's value before ``start[t]``.

    A block runs from the earliest start of its trials; a lane whose trial starts later computes from
    ``x0``, ``P0`` unwritten until its start, where it takes its checkpoint.  Per epoch and lane:
    :func:`.blocks.sparse_predict_lanes`, :func:`.blocks.window_push_lanes` and the M2M4 noise power,
    :func:`two_mode_iq_update_lanes`, symmetrisation, covariance test; no lane reads another, so every
    trial's result is the one it has alone, bit for bit.
    """
    L = blocks.LANES
    n_tr, k = y.shape
    keep = cov.shape[1] == k
    w = prm.window
    rows, cols, vals, nnz = prm.nz_rows[0], prm.nz_cols[0], prm.nz_vals[0], prm.nz_count[0]
    x, xn, dx = blocks.lanes_empty((3, L)), blocks.lanes_empty((3, L)), blocks.lanes_empty((3, L))
    ph0, ph1, k0, k1 = blocks.lanes_empty((3, L)), blocks.lanes_empty((3, L)), blocks.lanes_empty((3, L)), blocks.lanes_empty((3, L))
    P, FP, Q = blocks.lanes_empty((3, 3, L)), blocks.lanes_empty((3, 3, L)), blocks.lanes_empty((3, 3, L))
    b2, b4 = blocks.lanes_empty((w, L)), blocks.lanes_empty((w, L))
    s2, s4, p2, p4 = blocks.lanes_empty((L,)), blocks.lanes_empty((L,)), blocks.lanes_empty((L,)), blocks.lanes_empty((L,))
    yr, yi, r, lpp, lpm = blocks.lanes_empty((L,)), blocks.lanes_empty((L,)), blocks.lanes_empty((L,)), blocks.lanes_empty((L,)), blocks.lanes_empty((L,))
    mu, lo, cs, sn = blocks.lanes_empty((L,)), blocks.lanes_empty((L,)), blocks.lanes_empty((L,)), blocks.lanes_empty((L,))
    trial = np.empty(L, dtype=np.int64)
    for c0 in range(0, n_tr, L):
        m = blocks.lane_trials(c0, n_tr, trial)  # trials of this block written out
        first = k
        for ln in range(m):
            first = min(first, start[trial[ln]])
        if first >= k:
            continue
        b2[:, :] = 0.0
        b4[:, :] = 0.0
        s2[:] = 0.0
        s4[:] = 0.0
        pos = 0
        count = 0
        for ln in range(L):
            t = trial[ln]
            for a in range(3):
                x[a, ln] = prm.x0[t, a]
                for b in range(3):
                    P[a, b, ln] = prm.P0[t, a, b]
                    Q[a, b, ln] = prm.Q[t, a, b]
            r[ln] = prm.r_fixed
        for i in range(first if prm.adaptive else 0):  # the window over the epochs before the block's first
            for ln in range(L):
                v = y[trial[ln], i]
                yr[ln], yi[ln] = v.real, v.imag
            v2 = lane_load(yr, 0) * lane_load(yr, 0) + lane_load(yi, 0) * lane_load(yi, 0)
            lane_store(p2, 0, v2)
            lane_store(p4, 0, v2 * v2)
            pos, count = blocks.window_push_lanes(b2, b4, pos, s2, s4, count, p2, p4)
        for i in range(first, k):
            for ln in range(L):
                t = trial[ln]
                if i == start[t] and i > 0:  # this trial's checkpoint: the posterior of epoch i - 1
                    x[0, ln], x[1, ln], x[2, ln] = amp[t, i - 1], theta[t, i - 1], freq[t, i - 1]
                    for e in range(6):
                        a, b = COV_ENTRIES[e]
                        P[a, b, ln] = cov[t, i - 1, e]
                        P[b, a, ln] = cov[t, i - 1, e]
                v = y[t, i]
                yr[ln], yi[ln] = v.real, v.imag
                lpp[ln], lpm[ln] = prm.log_pp[t, i], prm.log_pm[t, i]
            if i > 0:
                blocks.sparse_predict_lanes(x, P, xn, FP, Q, rows, cols, vals, nnz)
            if prm.adaptive:
                v2 = lane_load(yr, 0) * lane_load(yr, 0) + lane_load(yi, 0) * lane_load(yi, 0)
                lane_store(p2, 0, v2)
                lane_store(p4, 0, v2 * v2)
                pos, count = blocks.window_push_lanes(b2, b4, pos, s2, s4, count, p2, p4)
                if count < w:
                    for ln in range(L):
                        r[ln] = 0.5 * prm.prior_noise[trial[ln]]
                else:
                    lane_store(r, 0, 0.5 * blocks.m2m4_split(lane_load(s2, 0) / count, lane_load(s4, 0) / count, prm.floor_fraction)[1])
            two_mode_iq_update_lanes(x, P, ph0, ph1, k0, k1, dx, cs, sn, r, yr, yi, lpp, lpm, mu, lo)
            for a in range(3):  # symmetrise
                for b in range(a + 1, 3):
                    hm = 0.5 * (lane_load(P, (3 * a + b) * L) + lane_load(P, (3 * b + a) * L))
                    lane_store(P, (3 * a + b) * L, hm)
                    lane_store(P, (3 * b + a) * L, hm)
            for ln in range(m):
                t = trial[ln]
                if i < start[t]:
                    continue
                if cov_fail[t] < 0 and not blocks.covariance_ok(P[1, 1, ln], P[2, 2, ln], P[1, 2, ln]):
                    cov_fail[t] = i
                p_plus[t, i], log_odds[t, i] = mu[ln], lo[ln]
                amp[t, i], theta[t, i], freq[t, i] = x[0, ln], x[1, ln], x[2, ln]
                if keep:
                    for e in range(6):
                        cov[t, i, e] = P[COV_ENTRIES[e][0], COV_ENTRIES[e][1], ln]
                cn0_db[t, i] = 10.0 * math.log10(blocks.cn0_from_powers(x[0, ln] * x[0, ln], 2.0 * r[ln], prm.ts))


def _positive(value: float, arg: str) -> float:
    value = float(value)
    if not (np.isfinite(value) and value > 0.0):
        raise ValueError(f"{arg} must be a finite number > 0 (got {value!r})")
    return value


def _per_trial(value, n_tr: int, arg: str) -> np.ndarray:
    out = np.asarray(value, dtype=float)
    if out.ndim == 0:
        out = np.full(n_tr, float(out))
    if out.shape != (n_tr,) or not np.all(np.isfinite(out)):
        raise ValueError(f"init.{arg} must hold one finite value per trial, shape ({n_tr},) (got shape {out.shape})")
    return out


def bit_log_priors(bit_prior, n_tr: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """``(log pi_+, log pi_-)`` shaped (trials, epochs) from ``TrackInit.bit_prior`` (None: pilot)."""
    if bit_prior is None:
        return np.zeros((n_tr, k)), np.full((n_tr, k), -np.inf)
    p = np.asarray(bit_prior, dtype=float)
    if p.shape not in ((k,), (n_tr, k)):
        raise ValueError(f"init.bit_prior must have shape ({k},) or ({n_tr}, {k}) (epochs or trials x epochs; got {p.shape})")
    if not np.all((p >= 0.0) & (p <= 1.0)):
        raise ValueError("init.bit_prior holds probabilities of d = +1: every value must be in [0, 1]")
    p = np.broadcast_to(p, (n_tr, k))
    with np.errstate(divide="ignore"):
        return np.log(p), np.log1p(-p)


@register("mm_kf")
@dataclass
class MMKF(Tracker):
    """Two-mode (d = +-1) multiple-model EKF on [A, phi, f] (module docstring)."""

    ts: float
    clock: str = "zhao_tcxo"
    q_form: str = "exact"
    q_freq_scale: float = 1.0
    amplitude_q: float = 0.0
    r: str | float = "m2m4"
    m2m4_window: int = DEFAULT_WINDOW
    p0_diag: tuple[float, float, float] = DEFAULT_P0
    amplitude0: float | None = None

    TRACKING_KEYS = ()
    #: the per-epoch outputs of :data:`OUTPUTS` and ``cov_fail_epoch`` (``covariance`` only from ``run(..., keep_covariance=True)``)
    PROVIDES = frozenset({*OUTPUTS.values(), "cov_fail_epoch"} - {"theta_d"})
    SCHEMA = {
        "clock": {"enum": sorted(clock_models.PRESETS), "description": "oscillator preset of scintrack.models.clock (default zhao_tcxo)"},
        "q_form": {"enum": list(Q_FORMS), "description": "clock process noise: exact two-state Q (default) or Zhao eq. (3) as written"},
        "q_freq_scale": {"type": "number", "exclusiveMinimum": 0, "description": "multiplier of the clock frequency variance (default 1)"},
        "amplitude_q": {"type": "number", "minimum": 0, "description": "amplitude process noise delta^2 per epoch, relative to amplitude0^2 (default 0)"},
        "r": {
            "description": "measurement noise: m2m4 (sliding M2M4 estimate, default) or a known sigma_v^2 per component [prompt units^2]",
            "oneOf": [{"const": "m2m4"}, {"type": "number", "exclusiveMinimum": 0}],
        },
        "m2m4_window": {"type": "integer", "minimum": 2, "description": f"M2M4 window [epochs] (default {DEFAULT_WINDOW})"},
        "p0_diag": {
            "type": "array", "items": {"type": "number", "minimum": 0}, "minItems": 3, "maxItems": 3,
            "description": f"initial variances [amplitude relative to amplitude0^2, phase rad^2, frequency Hz^2] (default {list(DEFAULT_P0)})",
        },
        "amplitude0": {"type": "number", "exclusiveMinimum": 0, "description": "initial amplitude [prompt units] (default: M2M4 over the first window)"},
    }

    def __post_init__(self):
        _positive(self.ts, "ts")
        clock_models.preset(self.clock)
        if self.q_form not in Q_FORMS:
            raise ValueError(f"q_form must be one of {Q_FORMS} (got {self.q_form!r})")
        _positive(self.q_freq_scale, "q_freq_scale")
        if not (np.isfinite(self.amplitude_q) and self.amplitude_q >= 0.0):
            raise ValueError(f"amplitude_q must be a finite number >= 0 (got {self.amplitude_q!r})")
        if self.r != "m2m4":
            if isinstance(self.r, str):
                raise ValueError(f"r must be 'm2m4' or a number > 0 (got {self.r!r})")
            _positive(self.r, "r")
        if int(self.m2m4_window) != self.m2m4_window or self.m2m4_window < 2:
            raise ValueError(f"m2m4_window must be an integer >= 2 epochs (got {self.m2m4_window!r})")
        p0 = np.asarray(self.p0_diag, dtype=float)
        if p0.shape != (3,) or not np.all(np.isfinite(p0) & (p0 >= 0.0)):
            raise ValueError(f"p0_diag must be 3 finite numbers >= 0 [rel. amplitude, rad^2, Hz^2] (got {self.p0_diag!r})")
        if self.amplitude0 is not None:
            _positive(self.amplitude0, "amplitude0")

    @classmethod
    def from_spec(cls, spec: Mapping[str, Any], context: TrackerContext) -> MMKF:
        kw = {key: spec[key] for key in ("clock", "q_form", "q_freq_scale", "amplitude_q", "r", "m2m4_window", "amplitude0") if key in spec}
        if "p0_diag" in spec:
            kw["p0_diag"] = tuple(float(v) for v in spec["p0_diag"])
        return cls(ts=float(context.ts), **kw)

    @staticmethod
    def label(name: str, spec: Mapping[str, Any]) -> str:
        quals = [str(spec.get("clock", "zhao_tcxo"))]
        if spec.get("q_form", "exact") == "zhao_eq3":
            quals.append("eq. 3 Q")
        if float(spec.get("q_freq_scale", 1.0)) != 1.0:
            quals.append(f"freq. Q x {float(spec['q_freq_scale']):g}")
        if spec.get("r", "m2m4") != "m2m4":
            quals.append("known R")
        return f"MM KF ({', '.join(quals)})"

    # --- model --------------------------------------------------------------------

    def transition(self) -> np.ndarray:
        """F of eq. (2) with phase in rad and frequency in Hz."""
        return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 2.0 * np.pi * self.ts], [0.0, 0.0, 1.0]])

    def clock_noise(self) -> np.ndarray:
        """Clock block of eq. (3) in (rad, Hz), times ``q_freq_scale`` on the frequency."""
        form = clock_models.process_noise if self.q_form == "exact" else clock_models.process_noise_zhao_eq3
        q = form(clock_models.preset(self.clock), self.ts, units="cycles")
        u = np.array([2.0 * np.pi, math.sqrt(self.q_freq_scale)])
        return q * np.outer(u, u)

    @property
    def adaptive(self) -> bool:
        return self.r == "m2m4"

    def params(self, y: np.ndarray, init: TrackInit) -> MmParams:
        n_tr, k = y.shape
        window = int(self.m2m4_window)
        signal, noise = m2m4(y[:, :window], axis=1, floor_fraction=M2M4_FLOOR)
        a0 = np.full(n_tr, float(self.amplitude0)) if self.amplitude0 is not None else np.sqrt(signal)
        x0 = np.stack([a0, _per_trial(init.phase, n_tr, "phase"), _per_trial(init.doppler_hz, n_tr, "doppler_hz")], axis=1)
        P0 = np.zeros((n_tr, 3, 3))
        P0[:, 0, 0] = self.p0_diag[0] * a0**2
        P0[:, 1, 1], P0[:, 2, 2] = self.p0_diag[1], self.p0_diag[2]
        Q = np.zeros((n_tr, 3, 3))
        Q[:, 0, 0] = self.amplitude_q * a0**2
        Q[:, 1:, 1:] = self.clock_noise()
        log_pp, log_pm = bit_log_priors(init.bit_prior, n_tr, k)
        r_fixed = 0.0 if self.adaptive else float(self.r)
        return MmParams(
            x0, P0, Q, np.ascontiguousarray(log_pp), np.ascontiguousarray(log_pm), self.adaptive, r_fixed, window, noise, float(self.ts),
            M2M4_FLOOR, *blocks.nonzeros(self.transition()),
        )

    @staticmethod
    def _prompts(y) -> np.ndarray:
        y = np.asarray(y)
        if y.ndim != 2 or y.shape[1] < 1 or not np.iscomplexobj(y):
            raise ValueError(f"y must be complex prompts shaped (trials, epochs) (got dtype {y.dtype}, shape {y.shape})")
        if not np.all(np.isfinite(y)):
            raise ValueError("y holds NaN or inf prompts; remove or zero-fill them before tracking")
        return np.ascontiguousarray(y, dtype=complex)

    # --- filters -----------------------------------------------------------------

    def run(self, y: np.ndarray, init: TrackInit, *, keep_covariance: bool = False) -> TrackOutput:
        """Compiled loop (:func:`mm_kf_kernel`).  ``keep_covariance``: also return the posterior covariance of every
        epoch, ``extras["covariance"]`` (trials, epochs, 6: :data:`COV_ENTRIES`), which :meth:`resume` needs."""
        y = self._prompts(y)
        *series, cov, cov_fail = mm_kf_kernel(y, self.params(y, init), keep_covariance)
        return self._output(dict(zip(OUTPUTS, series)), cov if keep_covariance else None, cov_fail)

    def resume(self, y: np.ndarray, init: TrackInit, previous: TrackOutput, previous_prior) -> TrackOutput:
        """:meth:`run` with ``init``'s bit priors, given ``previous``, the output of a run on the same ``y`` and
        initial state with the priors ``previous_prior`` (and ``keep_covariance``): each trial is filtered
        again only from the first epoch whose prior changed, starting from ``previous``' posterior of the
        epoch before; earlier epochs, and trials whose priors did not change, are copied.  The filter is
        causal and a trial's arithmetic does not depend on the other trials, so the result has the bits of
        ``run(y, init, keep_covariance=True)`` (``tests/test_mm_kf.py``); the fixed-point iterations of the
        IODE-check receiver (:func:`scintrack.experiments.gps_receiver.run_mm`) change the priors of a
        trial from some frame on, so most of each iteration is a copy.
        """
        y = self._prompts(y)
        n_tr, k = y.shape
        cov_prev = previous.extras.get("covariance")
        if cov_prev is None or cov_prev.shape != (n_tr, k, len(COV_ENTRIES)) or previous.theta_d.shape != (n_tr, k):
            raise ValueError(f"previous must be an output of run(..., keep_covariance=True) on the same {n_tr} x {k} prompts")
        old, new = (np.broadcast_to(np.asarray(1.0 if p is None else p, dtype=float), (n_tr, k)) for p in (previous_prior, init.bit_prior))  # None: pilot
        changed = old != new
        start = np.where(changed.any(axis=1), np.argmax(changed, axis=1), k).astype(np.int64)
        outs = {name: np.array(previous.theta_d if name == "theta" else previous.extras[key], dtype=float) for name, key in OUTPUTS.items()}
        cov = np.array(cov_prev, dtype=float)
        fail = np.asarray(previous.extras["cov_fail_epoch"], dtype=np.int64)
        cov_fail = np.where((fail >= 0) & (fail < start), fail, -1).astype(np.int64)
        mm_kf_loop(y, self.params(y, init), start, *outs.values(), cov, cov_fail)
        return self._output(outs, cov, cov_fail)

    @staticmethod
    def _output(outs: dict[str, np.ndarray], cov: np.ndarray | None, cov_fail: np.ndarray) -> TrackOutput:
        extras = {key: outs[name] for name, key in OUTPUTS.items() if name != "theta"}
        extras["cov_fail_epoch"] = cov_fail
        if cov is not None:
            extras["covariance"] = cov
        return TrackOutput(theta_d=outs["theta"], extras=extras)

    def reference(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """Textbook GPB1 in numpy, one time loop vectorised over trials.

        ``x = F x``, ``P = F P F^T + Q``; for each mode d: ``h_d = d A [cos phi, sin phi]``,
        its Jacobian ``H_d``, ``S_d = H_d P H_d^T + R``, ``K_d = P H_d^T S_d^-1``,
        ``x_d = x + K_d (y - h_d)``, ``P_d = (I - K_d H_d) P``,
        ``log L_d = -nu^T S_d^-1 nu / 2 - log det(2 pi S_d) / 2``;
        ``mu_d = exp(log pi_d + log L_d - logaddexp(..))``;
        ``x = sum mu_d x_d``, ``P = sum mu_d (P_d + (x_d - x)(x_d - x)^T)``.
        """
        y = self._prompts(y)
        prm = self.params(y, init)
        n_tr, k = y.shape
        F = self.transition()
        eye = np.eye(3)
        x = prm.x0[:, :, None].copy()  # (trials, 3, 1)
        P = prm.P0.copy()
        est = StreamingM2M4(n_tr, prm.window, prior_signal=0.0, prior_noise=0.0, min_epochs=1, floor_fraction=prm.floor_fraction)
        names = ("theta", "freq", "amp", "p_plus", "log_odds", "cn0")
        out = {name: np.empty((n_tr, k)) for name in names}
        cov_fail = np.full(n_tr, -1, dtype=np.int64)
        for i in range(k):
            if i > 0:
                x = F @ x
                P = F @ P @ F.T + prm.Q
            if prm.adaptive:
                noise = est.update(y[:, i])[1]
                r = 0.5 * (prm.prior_noise if i + 1 < prm.window else noise)
            else:
                r = np.full(n_tr, prm.r_fixed)
            R = r[:, None, None] * np.eye(2)
            z = np.stack([y[:, i].real, y[:, i].imag], axis=1)[:, :, None]  # (trials, 2, 1)
            A, c_, s_ = x[:, 0, 0], np.cos(x[:, 1, 0]), np.sin(x[:, 1, 0])
            modes = []
            for d, log_prior in ((1.0, prm.log_pp[:, i]), (-1.0, prm.log_pm[:, i])):
                h = d * np.stack([A * c_, A * s_], axis=1)[:, :, None]
                H = d * np.stack([np.stack([c_, -A * s_, 0 * A], axis=1), np.stack([s_, A * c_, 0 * A], axis=1)], axis=1)  # (trials, 2, 3)
                S = H @ P @ H.transpose(0, 2, 1) + R
                S_inv = np.linalg.inv(S)
                K = P @ H.transpose(0, 2, 1) @ S_inv
                nu = z - h
                log_l = -0.5 * (nu.transpose(0, 2, 1) @ S_inv @ nu)[:, 0, 0] - 0.5 * np.linalg.slogdet(2 * np.pi * S)[1]
                modes.append((x + K @ nu, (eye - K @ H) @ P, log_prior + log_l))
            w = np.stack([m[2] for m in modes])
            mu = np.exp(w - np.logaddexp(w[0], w[1]))
            x = sum(mu[j][:, None, None] * modes[j][0] for j in range(2))
            P = sum(mu[j][:, None, None] * (modes[j][1] + (modes[j][0] - x) @ (modes[j][0] - x).transpose(0, 2, 1)) for j in range(2))
            P = 0.5 * (P + P.transpose(0, 2, 1))
            cov_fail[(cov_fail < 0) & ~blocks.covariance_ok_ufunc(P[:, 1, 1], P[:, 2, 2], P[:, 1, 2])] = i
            out["theta"][:, i], out["freq"][:, i], out["amp"][:, i] = x[:, 1, 0], x[:, 2, 0], x[:, 0, 0]
            out["p_plus"][:, i], out["log_odds"][:, i] = mu[0], w[0] - w[1]
            out["cn0"][:, i] = 10.0 * np.log10(cn0_from_powers(x[:, 0, 0] ** 2, 2.0 * r, self.ts))
        return TrackOutput(
            theta_d=out["theta"],
            extras={"frequency_hz": out["freq"], "amplitude": out["amp"], "p_plus": out["p_plus"], "log_odds": out["log_odds"], "cn0_dbhz": out["cn0"],
                    "cov_fail_epoch": cov_fail},
        )
