"""Susi, Andreotti & Aquino 2014: the AKF PLL and the SAKF PLL (types ``susi_akf``, ``susi_sakf``).

One three-state Kalman filter on the discriminator output, two registered
types (the SAKF is the AKF plus the scintillation blocks):

* **State and dynamics** (eq. 3): ``x = [dphi (rad), df (Hz), da (Hz/s)]``,
  ``F = [[1, 2 pi T, pi T^2], [0, 1, T], [0, 0, 1]]`` (the same F as every KF
  of the package, :func:`.base.dynamics_F`).
* **Process noise** (eqs. 4-6): the continuous white noises on phase,
  frequency and rate have the diagonal PSD ``diag(S_dphi, S_df, S_da)``;
  the clock terms are eq. (5) ``S_dphi = f_L1^2 h0 / 2`` and eq. (6)
  ``S_df = f_L1^2 2 pi^2 h_-2`` of the configured oscillator
  (:mod:`scintrack.models.clock` presets, Brown & Hwang's h-values; phase in
  rad, i.e. eq. (5) times (2 pi)^2).  ``S_da`` is not given by the chapter
  ("the frequency rate error is only due to the LOS dynamics"): we use the
  Doppler-jerk PSD ``q_jerk_hz2_s3`` shared with the other KFs.  The discrete
  Q is exact for this model: :func:`.base.dynamics_Q` for ``S_da`` plus
  :func:`.blocks.phase_frequency_q` for ``S_dphi``, ``S_df``.
* **Measurement** (eq. 9): ``y = atan(Q/I)`` of the prompt against the
  predicted phase (``discriminator: atan``, the chapter's; ``atan2`` for
  data-free signals), ``H = [1, 0, 0]``; **R** (eq. 10)
  ``R = 1/(2 C/N0 Ts) (1 + 1/(2 C/N0 Ts))`` with the M2M4 C/N0 over the last
  ``cn0_window_s`` (``r: nominal`` fixes it at the scenario's C/N0).
* **SAKF** (eqs. 7, 8, 12): every ``update_s`` seconds the tracker's own
  carrier phase over the last ``window_s`` (3 s = 3000 samples at 1 ms) is
  detrended, its standard deviation is Phi3 and its periodogram gives the
  power law ``T f^-p`` (:mod:`scintrack.estimators.power_law`).  Eq. (7)
  adds ``S_dphi,scint = T f_irr^-p`` and eq. (8) ``S_df,scint = f_irr^2
  S_dphi,scint`` (f_irr = 0.19 Hz) to the clock PSDs: with the phase in rad
  and the frequency in Hz, ``phi(t) = 2 pi int f dt`` gives ``2 pi F(nu) =
  j 2 pi nu Phi(nu)``, so ``S_f(nu) = nu^2 S_phi(nu)`` exactly (rad^2/Hz to
  Hz^2/Hz; in cycles it would read ``(2 pi nu)^2 S_phi``).  The other
  readings of eqs. (7)-(8) are the spec key ``scintillation_q_reading``
  (:meth:`SusiKF.scint_psd`).  Eq. (12) weights the gain, ``K' = w K`` with
  ``w = alpha (1 + Phi3 / phi_ref)^-gamma`` (the chapter gives neither alpha
  nor K(Phi3): this monotone form, falling with Phi3 for gamma > 0, is our
  choice; ``alpha = 1, gamma = 0`` is no weighting).  The covariance of the
  weighted filter is propagated in Joseph form
  (:func:`.blocks.weighted_scalar_update_lanes`).

Modelling choices (``docs/modelling-choices.md``, Susi section): the window is
detrended by a least-squares quadratic (which removes the third-order
dynamics exactly; a causal 0.1-Hz Butterworth would ring for tens of
seconds after acquisition under a 100 Hz/s rate); Phi3, T and p are
refreshed every ``update_s`` (0.1 s) rather than at every epoch (the window
still slides: it always holds the last ``window_s``); before the first full
window the scintillation PSDs are 0 and ``w = alpha``.  The recorded monitors
(``phi3``, ``T``, ``p``, ``weight``) are therefore constant over each refresh
period, and :meth:`SusiKF.run` returns them as
:class:`~.held_series.HeldSeries` (one value per trial and period; read as
arrays they are the per-epoch series, the same bits), not as (trials, epochs)
arrays written epoch by epoch (a shard holds one value per refresh, not per epoch).

The compiled kernel (:func:`susi_kernel`) processes the epochs between two
refreshes for every trial and keeps its state across calls, so an AKF run
in one call and the same filter run in 0.1-s pieces give the same bits.

Lanes: :func:`susi_kernel` runs ``blocks.LANES`` (32) trials side by side,
with its state carried between calls in lane layout (:class:`SusiState`,
trial on the last axis, made by :func:`susi_state`): one SIMD vector per
matrix entry (:func:`.blocks.sparse_predict_lanes` with each lane's Q,
:func:`.blocks.weighted_scalar_update_lanes`, :func:`.blocks.m2m4_lanes`), the
discriminator (:mod:`.trig`'s sine, cosine, atan or atan2) one SIMD evaluation,
eq. (10) per lane.  No operation is fused or reassociated (no fast-math) and
no lane reads another, so a trial's result does not depend on its batch; a
last block with fewer trials computes copies of its last trial (discarded).
Tests (``tests/test_lane_kernels.py``): the kernel against
:meth:`SusiKF.reference`, the same bits in batches of 1, 31, 32, 33 and 40
trials (and over an irregular chunk schedule with new per-trial PSDs and
weights in every chunk), NaN and inf prompts.

:meth:`SusiKF.reference` is the textbook numpy form (explicit F, Q, H, S,
K, Joseph P).  Loop analysis for tests and docs: :func:`steady_state_gain`
(``scipy.linalg.solve_discrete_are``), :func:`loop_bandwidth_hz` (discrete,
from the closed-loop impulse response) and :func:`loop_bandwidth_closed_form`
(continuous third-order loop).

Config: ``{type: susi_akf, clock: ocxo}``,
``{type: susi_sakf, clock: rubidium, gain_weighting: {alpha: 1.0, phi_ref_rad: 0.5, exponent: 1.0}}``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from ..estimators.cn0 import M2M4_FLOOR, M2M4_MIN_EPOCHS, StreamingM2M4, cn0_from_powers
from ..models import clock as clock_models
from . import blocks
from .base import (
    Q_JERK_SCHEMA,
    Tracker,
    TrackerContext,
    TrackInit,
    TrackOutput,
    atan2_discriminator,
    dynamics_F,
    dynamics_Q,
    initial_state,
    spec_p0,
    spec_q_jerk,
)
from .design import compose
from .held_series import HeldSeries
from .registry import register

F_IRREGULARITY_HZ = 0.19  # Susi Sec. 3, after Forte & Radicella 2002
#: the SAKF's recorded monitors, refreshed with the scintillation blocks
MONITORS = ("phi3", "T", "p", "weight")
RECORDABLE = ("discriminator", "frequency_hz", "R", "phi3", "T", "p", "weight")


class SusiParams(NamedTuple):
    """Everything :func:`susi_kernel` needs besides the prompts and the running state."""

    P0: np.ndarray  # (3, 3)
    Q_base: np.ndarray  # (3, 3) clock + rate terms
    H: np.ndarray  # (3,)
    adaptive: bool
    r_fixed: float
    costas: bool
    window: int  # M2M4 window [epochs]
    prior_signal: float
    prior_noise: float
    ts: float
    min_epochs: int
    floor_fraction: float
    nz_rows: np.ndarray
    nz_cols: np.ndarray
    nz_vals: np.ndarray
    nz_count: np.ndarray


class SusiState(NamedTuple):
    """The running state :func:`susi_kernel` carries between calls, in blocks of ``blocks.LANES`` trials.

    Trial ``c0 + ln`` of block ``c0 / LANES`` is lane ``ln`` (the last axis); the
    lanes past the last trial of a short last block hold copies of that trial
    (:func:`susi_state`).  All float arrays C-contiguous and 64-byte aligned
    (:func:`.blocks.lanes_empty`).
    """

    x: np.ndarray  # (blocks, 3, LANES)
    P: np.ndarray  # (blocks, 3, 3, LANES)
    buf2: np.ndarray  # (blocks, window, LANES) M2M4 ring buffer of |P|^2
    buf4: np.ndarray  # (blocks, window, LANES) and of |P|^4
    sums: np.ndarray  # (blocks, 2, LANES) their running sums
    counters: np.ndarray  # (blocks, 2) int64: ring position and count (common to the lanes of a block)


def susi_state(x0: np.ndarray, P0: np.ndarray, window: int) -> SusiState:
    """The initial :class:`SusiState` of trials with initial states ``x0`` (trials, 3), ``P0`` (3, 3), empty M2M4 windows."""
    L = blocks.LANES
    n_tr = x0.shape[0]
    nb = -(-n_tr // L)
    lane_trial = np.minimum(np.arange(nb * L), n_tr - 1).reshape(nb, L)  # a short last block repeats its last trial
    x = blocks.lanes_empty((nb, 3, L))
    x[:] = np.asarray(x0, dtype=float)[lane_trial].transpose(0, 2, 1)
    P = blocks.lanes_empty((nb, 3, 3, L))
    P[:] = np.asarray(P0, dtype=float)[None, :, :, None]
    buf2, buf4 = blocks.lanes_empty((nb, window, L)), blocks.lanes_empty((nb, window, L))
    buf2[:], buf4[:] = 0.0, 0.0
    sums = blocks.lanes_empty((nb, 2, L))
    sums[:] = 0.0
    return SusiState(x, P, buf2, buf4, sums, np.zeros((nb, 2), dtype=np.int64))


@njit(cache=True)
def susi_kernel(y, i0, i1, prm, st, s_phi, s_f, weight, out, innov, freq, r_out, cov_fail):
    """Epochs [i0, i1) of every trial, ``blocks.LANES`` trials at a time (SIMD over trials); the state is
    carried in ``st`` (:class:`SusiState`).

    ``cov_fail`` (trials,): first epoch whose updated P fails
    :func:`.blocks.covariance_ok` (-1 none), carried across calls too.

    ``s_phi``/``s_f``/``weight`` (per trial) are the scintillation PSDs of
    eqs. (7)-(8) and the gain weight of eq. (12) in force over these epochs.

    Per epoch and lane: predict with the trial's Q, the discriminator on
    ``x[0]``, M2M4 and eq. (10), weighted Joseph update, covariance test; no
    lane reads another, so every trial's result is the one it has alone, bit for bit.
    """
    L = blocks.LANES
    n_tr = y.shape[0]
    rows, cols, vals, nnz = prm.nz_rows[0], prm.nz_cols[0], prm.nz_vals[0], prm.nz_count[0]
    nb = st.x.shape[0]
    if st.x.shape != (nb, 3, L) or nb * L < n_tr or (nb - 1) * L >= n_tr:
        raise ValueError("susi_kernel: the state does not match the trials (susi_state)")
    xn = blocks.lanes_empty((3, L))
    FP = blocks.lanes_empty((3, 3, L))
    Q = blocks.lanes_empty((3, 3, L))
    Qt = np.empty((3, 3))
    PH = blocks.lanes_empty((3, L))
    yr = blocks.lanes_empty((L,))
    yi = blocks.lanes_empty((L,))
    p2 = blocks.lanes_empty((L,))
    p4 = blocks.lanes_empty((L,))
    nu = blocks.lanes_empty((L,))
    R = blocks.lanes_empty((L,))
    w = blocks.lanes_empty((L,))
    sig = blocks.lanes_empty((L,))
    noi = blocks.lanes_empty((L,))
    trial = np.empty(L, dtype=np.int64)
    R[:] = prm.r_fixed
    for blk in range(nb):
        c0 = blk * L
        m = blocks.lane_trials(c0, n_tr, trial)  # trials of this block written out
        x = st.x[blk]
        P = st.P[blk]
        b2 = st.buf2[blk]
        b4 = st.buf4[blk]
        s2 = st.sums[blk, 0]
        s4 = st.sums[blk, 1]
        pos, count = st.counters[blk, 0], st.counters[blk, 1]
        for ln in range(L):
            t = trial[ln]
            Qt[:, :] = prm.Q_base
            blocks.phase_frequency_q(s_phi[t], s_f[t], prm.ts, Qt)
            for a in range(3):
                for b in range(3):
                    Q[a, b, ln] = Qt[a, b]
            w[ln] = weight[t]
        phase = x[0]
        for i in range(i0, i1):
            if i > 0:
                blocks.sparse_predict_lanes(x, P, xn, FP, Q, rows, cols, vals, nnz)
            blocks.prompt_discriminator_lanes(y, trial, i, phase, prm.costas, yr, yi, nu)
            if prm.adaptive:
                pos, count = blocks.m2m4_lanes(b2, b4, pos, s2, s4, count, yr, yi, p2, p4, prm.min_epochs, prm.prior_signal, prm.prior_noise,
                                               prm.floor_fraction, sig, noi)
                for ln in range(L):
                    R[ln] = blocks.costas_variance(blocks.cn0_from_powers(sig[ln], noi[ln], prm.ts), prm.ts)
            blocks.weighted_scalar_update_lanes(x, P, PH, prm.H, R, nu, w)
            for ln in range(m):
                t = trial[ln]
                if cov_fail[t] < 0 and not blocks.covariance_ok(P[0, 0, ln], P[1, 1, ln], P[0, 1, ln]):
                    cov_fail[t] = i
                out[t, i] = x[0, ln]
                innov[t, i] = nu[ln]
                freq[t, i] = x[1, ln]
                r_out[t, i] = R[ln]
        st.counters[blk, 0], st.counters[blk, 1] = pos, count


def quadratic_detrend(windows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Residual of a least-squares quadratic fit along the last axis (rows: trials), and its standard
    deviation per row (numpy's ``std``: the mean, then the mean square deviation from it).

    Each row is ``w - B (B^T w)`` with ``w = x - x[0]`` and ``B`` the orthonormal basis of
    :func:`_quadratic_basis`, computed by :func:`_detrend_rows` row by row in one fixed order, so a
    row's residual does not depend on which other rows are in the call.  A BLAS product
    (``w @ B``) does not promise that: OpenBLAS picks its kernel by the number of rows and the CPU,
    so the same trial can come out differently in a batch of 40 trials and in batches of 32 + 8
    (``tests/test_shard_batches.py``).
    """
    x = np.asarray(windows, dtype=float)
    rows = x if x.ndim == 2 else x.reshape(-1, x.shape[-1])
    out, std = np.empty(rows.shape), np.empty(rows.shape[0])
    _detrend_rows(rows, _quadratic_basis(x.shape[-1]), out, std)
    return out.reshape(x.shape), std.reshape(x.shape[:-1])


@njit(cache=True)
def _sum4(a, b, c, d):
    return (a + b) + (c + d)


@njit(cache=True)
def _detrend_rows(x, basis, out, std):
    """``out[t] = w - B (B^T w)``, ``w = x[t] - x[t, 0]``, and ``std[t]`` of ``out[t]``, for every row ``t``
    of ``x`` (rows, n).

    ``basis``: ``B^T``, (3, n).  Every sum over the samples (``B^T w``, the residual's sum, its squared
    deviations from the mean) is four partial sums over ``m = 4i + r``, added as ``(s0 + s1) + (s2 + s3)``,
    then the last ``n mod 4`` samples in order; ``B (B^T w)`` is ``c0 B[m, 0] + c1 B[m, 1] + c2 B[m, 2]``
    from the left.  Plain floating point (no fast-math): no operation is fused or reassociated.
    """
    n_rows, n = x.shape
    n4 = n - n % 4
    u, v, z = basis[0], basis[1], basis[2]
    for t in range(n_rows):
        row, res = x[t], out[t]
        x0 = row[0]
        a0 = a1 = a2 = a3 = 0.0
        b0 = b1 = b2 = b3 = 0.0
        e0 = e1 = e2 = e3 = 0.0
        for m in range(0, n4, 4):
            d0, d1, d2, d3 = row[m] - x0, row[m + 1] - x0, row[m + 2] - x0, row[m + 3] - x0
            a0 += d0 * u[m]
            a1 += d1 * u[m + 1]
            a2 += d2 * u[m + 2]
            a3 += d3 * u[m + 3]
            b0 += d0 * v[m]
            b1 += d1 * v[m + 1]
            b2 += d2 * v[m + 2]
            b3 += d3 * v[m + 3]
            e0 += d0 * z[m]
            e1 += d1 * z[m + 1]
            e2 += d2 * z[m + 2]
            e3 += d3 * z[m + 3]
        c0, c1, c2 = _sum4(a0, a1, a2, a3), _sum4(b0, b1, b2, b3), _sum4(e0, e1, e2, e3)
        for m in range(n4, n):
            d = row[m] - x0
            c0 += d * u[m]
            c1 += d * v[m]
            c2 += d * z[m]
        for m in range(n):
            res[m] = (row[m] - x0) - (c0 * u[m] + c1 * v[m] + c2 * z[m])
        a0 = a1 = a2 = a3 = 0.0
        for m in range(0, n4, 4):
            a0 += res[m]
            a1 += res[m + 1]
            a2 += res[m + 2]
            a3 += res[m + 3]
        total = _sum4(a0, a1, a2, a3)
        for m in range(n4, n):
            total += res[m]
        mean = total / n
        a0 = a1 = a2 = a3 = 0.0
        for m in range(0, n4, 4):
            d0, d1, d2, d3 = res[m] - mean, res[m + 1] - mean, res[m + 2] - mean, res[m + 3] - mean
            a0 += d0 * d0
            a1 += d1 * d1
            a2 += d2 * d2
            a3 += d3 * d3
        total = _sum4(a0, a1, a2, a3)
        for m in range(n4, n):
            d = res[m] - mean
            total += d * d
        std[t] = math.sqrt(total / n)


@functools.lru_cache(maxsize=8)
def _quadratic_basis(n: int) -> np.ndarray:
    """``B^T`` (3, n): the orthonormal basis of {1, m, m^2} on m in [-1, 1] (QR), one row per
    basis vector (cached per window length, read-only)."""
    m = np.linspace(-1.0, 1.0, n)
    basis, _ = np.linalg.qr(np.stack([np.ones(n), m, m * m], axis=1))
    basis = np.ascontiguousarray(basis.T)
    basis.setflags(write=False)
    return basis


@dataclass
class GainWeighting:
    """Eq. (12): ``w = alpha (1 + Phi3 / phi_ref)^-exponent``."""

    alpha: float = 1.0
    phi_ref_rad: float = 0.5
    exponent: float = 1.0

    def __call__(self, phi3: np.ndarray) -> np.ndarray:
        return self.alpha * (1.0 + np.asarray(phi3) / self.phi_ref_rad) ** (-self.exponent)


#: the readings of eqs. (7)-(8) (spec key ``scintillation_q_reading``; docs/REPRODUCTION.md, U1-U4)
SCINTILLATION_Q_READINGS = ("literal", "literal_cycles", "eq8_only", "freq_random_walk", "increment_variance")
#: points of the Gauss-Legendre rule in log f of the ``increment_variance`` integral
INCREMENT_NODES = 256


def scintillation_q_psd(reading: str, T: np.ndarray, p: np.ndarray, f_irr: float, ts: float) -> tuple[np.ndarray, np.ndarray]:
    """(S_dphi,scint in rad^2/s, S_df,scint in Hz^2/s) that the reading of eqs. (7)-(8) adds to the white
    process noises of the phase and frequency states, from the power law ``S_phi(f) = T f^-p`` (one-sided,
    rad^2/Hz, T at 1 Hz; :mod:`scintrack.estimators.power_law`); non-finite T or p give 0.

    * ``literal`` (U1, rad-consistent; the default): eq. (7) ``S_dphi = T f_irr^-p`` as the intensity of a
      phase random walk and eq. (8) ``S_df = f_irr^2 S_dphi``.  With phi in rad and f in Hz,
      ``phi = 2 pi int f dt`` gives ``S_f(nu) = nu^2 S_phi(nu)`` exactly (rad^2/Hz to Hz^2/Hz).
    * ``literal_cycles`` (U1 as first coded): the same with eq. (8) divided by (2 pi)^2,
      ``S_df = f_irr^2 T f_irr^-p / (2 pi)^2``, a relation that would hold with phi in cycles; kept
      only as a named reading.
    * ``eq8_only`` (U2): no phase term, ``S_df = f_irr^2 T f_irr^-p``.
    * ``freq_random_walk`` (U3): no phase term; a frequency random walk of intensity ``S_df`` has the
      one-sided frequency PSD ``2 S_df / (2 pi nu)^2`` and so the phase PSD ``2 S_df / ((2 pi)^2 nu^4)``;
      it equals ``T f^-p`` at ``f_irr`` for ``S_df = 2 pi^2 f_irr^4 T f_irr^-p``.
    * ``increment_variance`` (U4): no frequency term; the per-step phase noise is the variance of the
      ``ts`` increment of the ``T f^-p`` process, ``V = int_{f_irr}^{1/(2 ts)} T f^-p 4 sin^2(pi f ts) df``
      (rad^2), i.e. ``S_dphi = V / ts`` (Q[0, 0] gains ``S_dphi ts = V``); the integral by a
      :data:`INCREMENT_NODES`-point Gauss-Legendre rule in ``ln f``.
    """
    T = np.asarray(T, dtype=float)
    p = np.asarray(p, dtype=float)
    ok = np.isfinite(T) & np.isfinite(p)
    T0, p0 = np.where(ok, T, 0.0), np.where(ok, p, 0.0)
    at_irr = T0 * f_irr ** (-p0)
    zero = np.zeros_like(at_irr)
    if reading == "literal":
        s_phi, s_f = at_irr, f_irr**2 * at_irr
    elif reading == "literal_cycles":
        s_phi, s_f = at_irr, f_irr**2 * at_irr / (2 * math.pi) ** 2
    elif reading == "eq8_only":
        s_phi, s_f = zero, f_irr**2 * at_irr
    elif reading == "freq_random_walk":
        s_phi, s_f = zero, 2 * math.pi**2 * f_irr**4 * at_irr
    elif reading == "increment_variance":
        s_phi, s_f = increment_variance(T0, p0, f_irr, ts) / ts, zero
    else:
        raise ValueError(f"scintillation_q_reading {reading!r} is not one of {', '.join(SCINTILLATION_Q_READINGS)}")
    return np.where(ok & np.isfinite(s_phi), s_phi, 0.0), np.where(ok & np.isfinite(s_f), s_f, 0.0)


def increment_variance(T: np.ndarray, p: np.ndarray, f_lo: float, ts: float) -> np.ndarray:
    """``int_{f_lo}^{1/(2 ts)} T f^-p 4 sin^2(pi f ts) df`` [rad^2] per element of ``T``, ``p`` (Gauss-Legendre in
    ``u = ln f``: ``int T e^{(1-p) u} 4 sin^2(pi e^u ts) du``, smooth in u)."""
    x, wq = np.polynomial.legendre.leggauss(INCREMENT_NODES)
    a, b = math.log(f_lo), math.log(0.5 / ts)
    u = 0.5 * (b - a) * x + 0.5 * (b + a)
    f = np.exp(u)
    T, p = np.asarray(T, dtype=float), np.asarray(p, dtype=float)
    g = np.exp(np.multiply.outer(1.0 - p, u)) * (4 * np.sin(math.pi * f * ts) ** 2)
    return T * (0.5 * (b - a)) * (g @ wq)


@dataclass
class SusiKF(Tracker):
    SPEC_OVERRIDES = {"q_jerk_hz2_s3": "q_jerk_hz2_s3"}
    PROVIDES = frozenset({*RECORDABLE, "cov_fail_epoch"})

    ts: float
    clock: str
    q_jerk: float
    nominal_cn0_hz: float
    p0_diag: tuple[float, float, float]
    amplitude: float = 1.0
    discriminator: str = "atan"
    adaptive_r: bool = True
    cn0_window_s: float = 0.5
    scintillation: bool = False  # the SAKF blocks (eqs. 7, 8, 12)
    scintillation_q: bool = True  # eqs. (7)-(8) on (SAKF)
    scintillation_q_reading: str = "literal"  # which reading of eqs. (7)-(8): SCINTILLATION_Q_READINGS
    weighting: GainWeighting = field(default_factory=GainWeighting)
    window_s: float = 3.0
    update_s: float = 0.1
    fit_band_hz: tuple[float, float] = (0.5, 5.0)
    f_irregularity_hz: float = F_IRREGULARITY_HZ
    record: tuple[str, ...] = ("discriminator", "frequency_hz", "phi3", "T", "p", "weight")

    def request(self, wanted: Collection[str] = ()) -> frozenset[str]:
        """The series of ``record`` it computes (the monitors: SAKF only) and ``cov_fail_epoch``, whatever is wanted."""
        return frozenset({*(name for name in self.record if self.scintillation or name not in MONITORS), "cov_fail_epoch"})

    # --- model ---------------------------------------------------------------

    def clock_psd(self) -> tuple[float, float]:
        """(S_dphi in rad^2/s, S_df in Hz^2/s) of eqs. (5)-(6) for the oscillator."""
        model = clock_models.preset(self.clock)
        f0 = clock_models.F_L1_HZ
        return (2 * math.pi * f0) ** 2 * model.s_f, f0**2 * model.s_g

    def q_base(self) -> np.ndarray:
        q = dynamics_Q(self.q_jerk, self.ts).copy()
        blocks.phase_frequency_q(*self.clock_psd(), self.ts, q)
        return q

    def scint_psd(self, T: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Eqs. (7)-(8): (S_dphi,scint rad^2/s, S_df,scint Hz^2/s) from the power law at f_irr, in the
        reading ``scintillation_q_reading`` (:func:`scintillation_q_psd`)."""
        return scintillation_q_psd(self.scintillation_q_reading, T, p, self.f_irregularity_hz, self.ts)

    @property
    def nominal_noise(self) -> float:
        return self.amplitude**2 / (self.nominal_cn0_hz * self.ts)

    @property
    def cn0_window(self) -> int:
        return max(int(round(self.cn0_window_s / self.ts)), 1)

    @property
    def n_window(self) -> int:
        return int(round(self.window_s / self.ts))

    @property
    def hop(self) -> int:
        return max(int(round(self.update_s / self.ts)), 1)

    def params(self) -> SusiParams:
        F = dynamics_F(self.ts)
        return SusiParams(
            np.diag(np.asarray(self.p0_diag, dtype=float)), self.q_base(), np.array([1.0, 0.0, 0.0]), bool(self.adaptive_r),
            float(blocks.costas_variance(self.nominal_cn0_hz, self.ts)), self.discriminator == "atan", self.cn0_window,
            float(self.amplitude**2), float(self.nominal_noise), float(self.ts), M2M4_MIN_EPOCHS, M2M4_FLOOR, *blocks.nonzeros(F),
        )

    # --- the scintillation blocks (between kernel calls) ----------------------

    def scintillation_update(self, phases: np.ndarray) -> dict[str, np.ndarray]:
        """Phi3, T, p, the eq. (7)-(8) PSDs and the eq. (12) weight from the last window of carrier phases."""
        from ..estimators.power_law import estimate_power_law

        resid, phi3 = quadratic_detrend(phases)
        _, T, p = estimate_power_law(resid, self.ts, window_s=resid.shape[-1] * self.ts, f_lo_hz=self.fit_band_hz[0], f_hi_hz=self.fit_band_hz[1])
        T, p = T[:, 0], p[:, 0]
        if self.scintillation_q:
            s_phi, s_f = self.scint_psd(T, p)
        else:
            s_phi, s_f = np.zeros_like(phi3), np.zeros_like(phi3)
        return {"phi3": phi3, "T": T, "p": p, "s_phi": s_phi, "s_f": s_f, "weight": self.weighting(phi3)}

    def _initial_scint(self, n_tr: int) -> dict[str, np.ndarray]:
        nan = np.full(n_tr, np.nan)
        return {"phi3": nan, "T": nan, "p": nan, "s_phi": np.zeros(n_tr), "s_f": np.zeros(n_tr), "weight": np.full(n_tr, self.weighting.alpha)}

    def _schedule(self, k: int) -> list[tuple[int, int]]:
        hop = self.hop if self.scintillation else k
        return [(i0, min(i0 + hop, k)) for i0 in range(0, k, hop)]

    def _outputs(self, out, series, cov_fail) -> TrackOutput:
        """The recorded series and ``cov_fail_epoch`` (trials,; -1 none), always."""
        return TrackOutput(theta_d=out, extras={**{name: series[name] for name in self.record if name in series}, "cov_fail_epoch": cov_fail})

    # --- compiled loop -------------------------------------------------------------

    def run(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        y = np.ascontiguousarray(y, dtype=complex)
        n_tr, k = y.shape
        prm = self.params()
        st = susi_state(initial_state(init, 3), prm.P0, prm.window)
        out, innov, freq, r_out = (np.empty((n_tr, k)) for _ in range(4))
        cov_fail = np.full(n_tr, -1, dtype=np.int64)
        series = {"discriminator": innov, "frequency_hz": freq, "R": r_out}
        schedule = self._schedule(k)
        if self.scintillation:  # one value per trial and chunk of the schedule (held over its epochs: HeldSeries)
            held = {name: np.empty((len(schedule), n_tr)) for name in MONITORS}
        sc = self._initial_scint(n_tr)
        for h, (i0, i1) in enumerate(schedule):
            susi_kernel(y, i0, i1, prm, st, sc["s_phi"], sc["s_f"], sc["weight"], out, innov, freq, r_out, cov_fail)
            if self.scintillation:
                for name in MONITORS:
                    held[name][h] = sc[name]
                if i1 >= self.n_window:
                    sc = self.scintillation_update(out[:, i1 - self.n_window : i1])
        if self.scintillation:
            starts = np.array([i0 for i0, _ in schedule], dtype=np.int64)
            series.update({name: HeldSeries(np.ascontiguousarray(v.T), starts, k) for name, v in held.items()})
        return self._outputs(out, series, cov_fail)

    # --- textbook form -------------------------------------------------------------

    def reference(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """Textbook numpy Kalman filter, vectorised over trials, same refresh schedule.

        ``x = F x``, ``P = F P F^T + Q`` with ``Q = Q_clock,rate + Q(S_dphi,scint, S_df,scint)``;
        ``nu = disc(y, H x)``, ``S = H P H^T + R``, ``K = P H^T / S``,
        ``x += w K nu``, ``P = (I - w K H) P (I - w K H)^T + w^2 K R K^T``.
        """
        n_tr, k = y.shape
        F = dynamics_F(self.ts)
        H = np.array([[1.0, 0.0, 0.0]])
        eye = np.eye(3)
        q_base = self.q_base()
        c = 2 * math.pi
        x = initial_state(init, 3)[:, :, None]
        P = np.broadcast_to(np.diag(np.asarray(self.p0_diag, dtype=float)), (n_tr, 3, 3)).copy()
        cn0 = StreamingM2M4(n_tr, self.cn0_window, prior_signal=self.amplitude**2, prior_noise=self.nominal_noise, min_epochs=M2M4_MIN_EPOCHS, floor_fraction=M2M4_FLOOR)
        out, innov, freq, r_out = (np.empty((n_tr, k)) for _ in range(4))
        cov_fail = np.full(n_tr, -1, dtype=np.int64)
        series = {"discriminator": innov, "frequency_hz": freq, "R": r_out}
        if self.scintillation:
            series.update({name: np.empty((n_tr, k)) for name in MONITORS})  # every chunk of the schedule writes its epochs
        sc = self._initial_scint(n_tr)
        ts = self.ts
        for i0, i1 in self._schedule(k):
            sp, sf = sc["s_phi"], sc["s_f"]
            Q = np.broadcast_to(q_base, (n_tr, 3, 3)).copy()
            Q[:, 0, 0] += sp * ts + c * c * sf * ts**3 / 3
            Q[:, 0, 1] += c * sf * ts**2 / 2
            Q[:, 1, 0] += c * sf * ts**2 / 2
            Q[:, 1, 1] += sf * ts
            wgt = sc["weight"][:, None, None]
            for i in range(i0, i1):
                if i > 0:
                    x = F @ x
                    P = F @ P @ F.T + Q
                yi = y[:, i]
                if self.adaptive_r:
                    sig, noi = cn0.update(yi)
                    R = blocks.costas_variance_ufunc(cn0_from_powers(sig, noi, ts), ts)
                else:
                    R = np.full(n_tr, blocks.costas_variance(self.nominal_cn0_hz, ts))
                phase = (H @ x)[:, 0, 0]
                if self.discriminator == "atan":
                    nu = blocks.atan_discriminator_ufunc(yi.real, yi.imag, phase)
                else:
                    nu = atan2_discriminator(yi, phase)
                S = H @ P @ H.T + R[:, None, None]
                K = wgt * (P @ H.T / S)
                x = x + K * nu[:, None, None]
                IKH = eye - K @ H
                P = IKH @ P @ np.swapaxes(IKH, 1, 2) + K @ np.swapaxes(K, 1, 2) * R[:, None, None]
                cov_fail[(cov_fail < 0) & ~blocks.covariance_ok_ufunc(P[:, 0, 0], P[:, 1, 1], P[:, 0, 1])] = i
                out[:, i], innov[:, i], freq[:, i], r_out[:, i] = x[:, 0, 0], nu, x[:, 1, 0], R
            if self.scintillation:
                for name in MONITORS:
                    series[name][:, i0:i1] = sc[name][:, None]
                if i1 >= self.n_window:
                    sc = self.scintillation_update(out[:, i1 - self.n_window : i1])
        return self._outputs(out, series, cov_fail)

    # --- construction ----------------------------------------------------------------

    @classmethod
    def _kwargs(cls, spec: Mapping[str, Any], context: TrackerContext) -> dict[str, Any]:
        return dict(
            ts=context.ts, clock=spec_clock(spec, context), q_jerk=spec_q_jerk(spec, context), nominal_cn0_hz=context.cn0_hz,
            p0_diag=spec_p0(context), amplitude=float(context.tracking["amplitude"]), discriminator=str(spec.get("discriminator", "atan")),
            adaptive_r=spec.get("r", "adaptive") == "adaptive", cn0_window_s=float(spec.get("cn0_window_s", 0.5)),
        )


def spec_clock(spec: Mapping[str, Any], context: TrackerContext) -> str:
    """The oscillator preset: the spec's, or (``scenario``, the default) the scenario's
    receiver clock, or ``ocxo`` on a scenario without one (the CSM scenarios have no clock noise)."""
    name = str(spec.get("clock", "scenario"))
    return str(context.scenario.get("clock") or "ocxo") if name == "scenario" else name


SUSI_TRACKING_KEYS = ("amplitude", "cn0_dbhz", "p0_diag", "q_jerk_hz2_s3")
AKF_SCHEMA = {
    "clock": {"enum": ["scenario", *sorted(clock_models.PRESETS)], "description": "receiver oscillator of eqs. (5)-(6): a preset, or scenario (default: the scenario's clock, ocxo where it has none)"},
    "discriminator": {"enum": ["atan", "atan2"], "description": "eq. (9) atan(Q/I) (default) or the four-quadrant atan2 for data-free signals"},
    "r": {"enum": ["adaptive", "nominal"], "description": "eq. (10) at the on-line M2M4 C/N0 (default) or at the scenario's C/N0"},
    "cn0_window_s": {"type": "number", "exclusiveMinimum": 0, "description": "M2M4 C/N0 window [s] (default 0.5)"},
    "q_jerk_hz2_s3": Q_JERK_SCHEMA,
}
SAKF_SCHEMA = {
    **AKF_SCHEMA,
    "scintillation_q": {"type": "boolean", "description": "add eqs. (7)-(8) to Q (default true)"},
    "scintillation_q_reading": {"enum": list(SCINTILLATION_Q_READINGS),
                                "description": "reading of eqs. (7)-(8) (default literal; scintillation_q_psd gives each formula)"},
    "window_s": {"type": "number", "exclusiveMinimum": 0, "description": "Phi3 / T, p window [s] (default 3)"},
    "update_s": {"type": "number", "exclusiveMinimum": 0, "description": "refresh period of Phi3, T, p [s] (default 0.1)"},
    "fit_band_hz": {"type": "array", "items": {"type": "number", "exclusiveMinimum": 0}, "minItems": 2, "maxItems": 2,
                    "description": "band of the power-law fit [Hz] (default [0.5, 5])"},
    "f_irregularity_hz": {"type": "number", "exclusiveMinimum": 0, "description": "f of eqs. (7)-(8) (default 0.19 Hz)"},
    "gain_weighting": {
        "type": "object", "additionalProperties": False,
        "properties": {
            "alpha": {"type": "number", "exclusiveMinimum": 0, "maximum": 2},
            "phi_ref_rad": {"type": "number", "exclusiveMinimum": 0},
            "exponent": {"type": "number", "minimum": -2, "maximum": 4},
        },
        "description": "eq. (12) K' = alpha (1 + Phi3/phi_ref)^-exponent K (default alpha 1, phi_ref 0.5 rad, exponent 1)",
    },
}


@register("susi_akf")
class SusiAKF(SusiKF):
    """AKF PLL: clock-only Q (eqs. 4-6), R from the monitored C/N0 (eq. 10)."""

    TRACKING_KEYS = SUSI_TRACKING_KEYS
    SCHEMA = AKF_SCHEMA

    @classmethod
    def from_spec(cls, spec: Mapping[str, Any], context: TrackerContext) -> SusiAKF:
        return cls(**cls._kwargs(spec, context))

    @staticmethod
    def label(name: str, spec: Mapping[str, Any]) -> str:
        return compose("AKF PLL", [str(spec["clock"])] if spec.get("clock", "scenario") != "scenario" else [])


@register("susi_sakf")
class SusiSAKF(SusiKF):
    """SAKF PLL: the AKF plus the scintillation PSDs (eqs. 7-8) and the Phi3 gain weighting (eq. 12)."""

    TRACKING_KEYS = SUSI_TRACKING_KEYS
    SCHEMA = SAKF_SCHEMA

    @classmethod
    def from_spec(cls, spec: Mapping[str, Any], context: TrackerContext) -> SusiSAKF:
        gw = dict(spec.get("gain_weighting", {}))
        band = spec.get("fit_band_hz", (0.5, 5.0))
        return cls(
            **cls._kwargs(spec, context), scintillation=True, scintillation_q=bool(spec.get("scintillation_q", True)),
            scintillation_q_reading=str(spec.get("scintillation_q_reading", "literal")),
            weighting=GainWeighting(float(gw.get("alpha", 1.0)), float(gw.get("phi_ref_rad", 0.5)), float(gw.get("exponent", 1.0))),
            window_s=float(spec.get("window_s", 3.0)), update_s=float(spec.get("update_s", 0.1)), fit_band_hz=(float(band[0]), float(band[1])),
            f_irregularity_hz=float(spec.get("f_irregularity_hz", F_IRREGULARITY_HZ)),
        )

    @staticmethod
    def label(name: str, spec: Mapping[str, Any]) -> str:
        gw = spec.get("gain_weighting", {})
        quals = [str(spec["clock"])] if spec.get("clock", "scenario") != "scenario" else []
        if "alpha" in gw:
            quals.append(f"alpha = {float(gw['alpha']):g}")
        if "exponent" in gw:
            quals.append(f"gamma = {float(gw['exponent']):g}")
        if spec.get("scintillation_q") is False:
            quals.append("no scint. Q")
        elif spec.get("scintillation_q_reading", "literal") != "literal":
            quals.append(f"Q: {spec['scintillation_q_reading']}")
        return compose("SAKF PLL", quals)


# --- loop analysis (tests, docs) --------------------------------------------------------


def steady_state_gain(tracker: SusiKF, cn0_hz: float | None = None, scint: tuple[float, float] | None = None) -> np.ndarray:
    """Steady-state Kalman gain for fixed Q (clock + rate terms, plus the scintillation PSDs ``scint`` =
    (S_dphi,scint, S_df,scint) of :meth:`SusiKF.scint_psd` when given) and R = eq. (10) at ``cn0_hz``.

    ``P`` (prior) solves the discrete algebraic Riccati equation
    ``P = F P F^T - F P H^T (H P H^T + R)^-1 H P F^T + Q``
    (``scipy.linalg.solve_discrete_are(F^T, H^T, Q, R)``); ``K = P H^T / (H P H^T + R)``.
    """
    from scipy.linalg import solve_discrete_are

    F = dynamics_F(tracker.ts)
    H = np.array([[1.0, 0.0, 0.0]])
    R = float(blocks.costas_variance(tracker.nominal_cn0_hz if cn0_hz is None else cn0_hz, tracker.ts))
    Q = tracker.q_base()
    if scint is not None:
        blocks.phase_frequency_q(float(scint[0]), float(scint[1]), tracker.ts, Q)
    P = solve_discrete_are(F.T, H.T, Q, np.array([[R]]))
    return (P @ H.T / (H @ P @ H.T + R))[:, 0]


def loop_bandwidth_hz(K: np.ndarray, ts: float, n: int = 200_000) -> float:
    """Noise bandwidth of the steady-state filter as a loop: ``B = sum(h^2) / (2 Ts)`` of the
    impulse response from the measured phase to the phase estimate (unit DC gain)."""
    from scipy import signal

    F = dynamics_F(ts)
    H = np.array([[1.0, 0.0, 0.0]])
    K = np.asarray(K, dtype=float)[:, None]
    A = (np.eye(3) - K @ H) @ F  # x+_k = (I - K H) F x+_{k-1} + K z_k
    _, h = signal.dimpulse((A, K, H, np.zeros((1, 1)), ts), n=n)
    h = np.asarray(h[0]).ravel()
    return float(np.sum(h**2) / (2 * ts))


def loop_bandwidth_closed_form(K: np.ndarray, ts: float) -> float:
    """Continuous third-order loop with the same gains: ``c1 = k1/T``, ``c2 = 2 pi k2/T``,
    ``c3 = 2 pi k3/T`` in ``H(s) = (c1 s^2 + c2 s + c3)/(s^3 + c1 s^2 + c2 s + c3)``, whose
    noise bandwidth is ``B = (c1^2 c2 + c2^2 - c1 c3) / (4 (c1 c2 - c3))`` Hz (Kaplan's
    ``omega_0 (a3 b3^2 + a3^2 - b3) / (4 (a3 b3 - 1))`` in these coefficients)."""
    k1, k2, k3 = (float(v) for v in K)
    c1, c2, c3 = k1 / ts, 2 * math.pi * k2 / ts, 2 * math.pi * k3 / ts
    return (c1 * c1 * c2 + c2 * c2 - c1 * c3) / (4.0 * (c1 * c2 - c3))
