"""Discriminator-based Kalman filters: KF, AKF and AKF-AR (Vila-Valls 2018, Sec. V-A, VI).

One filter, three registered types (they differ only in R and in the state):

* ``kf``: state ``x1 = [theta_d, f_d, f_r]`` (eq. 8, m = 3), measurement the
  ATAN2 discriminator output on the predicted phase, ``H = [1, 0, 0]``, fixed
  ``R`` = eq. (12) at the nominal C/N0 ("heuristically set from the expected
  propagation conditions").
* ``akf``: the same with ``R_k`` = eq. (12) at the on-line M2M4 C/N0 estimate
  over ``tracking.cn0_window`` epochs.
* ``akf_ar`` (ref. [14]): AKF with the state augmented by the AR(p)
  scintillation phase ``[theta_s,k .. theta_s,k-p+1]`` (eq. 9), ``H = [1, 0, 0, 1, 0..]``;
  AR parameters fixed by ``design`` (:mod:`.design`; no adaptation).

The discriminator measures ``H x - H x_pred`` wrapped to (-pi, pi], so the
innovation is the discriminator output itself.  The kernel
(:func:`kf_kernel`) is made of :mod:`.blocks` (predict, ATAN2, M2M4, eq. 12,
scalar update); :meth:`DiscriminatorKF.reference` is the textbook matrix form.

Lanes: :func:`kf_kernel` runs ``blocks.LANES`` (32) trials side by side: every
state array carries the trial on its last axis and each matrix entry of the
32 trials is one SIMD vector (``Lanes``), so the core works on 32 independent
filters instead of waiting on one filter's chain of dependent operations.  The
blocks are :func:`.blocks.sparse_predict_lanes` (over the non-zeros of F),
:func:`.blocks.scalar_update_lanes`, :func:`.blocks.m2m4_lanes`, and the
discriminator is one SIMD evaluation of :mod:`.trig`'s sine, cosine and atan2
(:func:`.blocks.atan2_discriminator_lanes`); exp and erf of eq. (12) are libm
calls per lane.  Per lane no operation is fused or reassociated (no
fast-math) and no lane reads another, so a trial's result does not depend on
the batch it runs in; a last block with fewer trials computes copies of its
last trial (discarded).  Tests (``tests/test_lane_kernels.py``): the kernel
against :meth:`DiscriminatorKF.reference` within a stated tolerance, the same
bits in batches of 1, 31, 32, 33 and 40 trials, NaN and inf prompts.

Config: ``{type: kf|akf, q_jerk_hz2_s3: ..}``, ``{type: akf_ar, design: .., phase_order: ..}``.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from ..estimators.cn0 import M2M4_FLOOR, M2M4_MIN_EPOCHS, StreamingM2M4, cn0_from_powers
from ..simd.lanes import lane_load, lane_splat, lane_store
from . import blocks
from .base import (
    DESIGN_SCHEMA,
    PHASE_ORDER_SCHEMA,
    Q_JERK_SCHEMA,
    Tracker,
    TrackerContext,
    TrackInit,
    TrackOutput,
    atan2_discriminator,
    atan_variance,
    companion,
    dynamics_F,
    dynamics_Q,
    initial_state,
    spec_p0,
    spec_q_jerk,
)
from .design import compose, design_ar, design_point, explicit_design_s4, q_qualifier
from .registry import register


class KfParams(NamedTuple):
    """Everything :func:`kf_kernel` needs besides the prompts."""

    x0: np.ndarray  # (trials, n) initial state
    P0: np.ndarray  # (n, n)
    Q: np.ndarray  # (n, n)
    H: np.ndarray  # (n,)
    adaptive: bool  # R from the on-line C/N0 (AKF) or fixed
    r_fixed: float
    window: int  # M2M4 window [epochs]
    prior_signal: float  # M2M4 values before min_epochs
    prior_noise: float
    ts: float
    min_epochs: int
    floor_fraction: float
    nz_rows: np.ndarray  # non-zeros of F (blocks.nonzeros)
    nz_cols: np.ndarray
    nz_vals: np.ndarray
    nz_count: np.ndarray


@njit(cache=True)
def kf_kernel(y, prm):
    """The discriminator KF, ``blocks.LANES`` trials at a time (trial on the last axis: SIMD over trials).

    Per epoch and lane: predict, ATAN2 on ``H x``, M2M4 and eq. (12), scalar
    update, covariance test; no lane reads another, so every trial's result is
    the one it has alone, bit for bit.  The M2M4 ring buffers are (window, LANES)
    with a position and count common to the lanes (every lane pushes once per
    epoch).  A short last block computes copies of its last trial (not written).
    """
    L = blocks.LANES
    n_tr, k = y.shape
    n = prm.Q.shape[0]
    rows, cols, vals, nnz = prm.nz_rows[0], prm.nz_cols[0], prm.nz_vals[0], prm.nz_count[0]
    out = np.empty((n_tr, k))
    r_out = np.empty((n_tr, k)) if prm.adaptive else np.empty((0, 0))
    tot = np.empty((n_tr, k)) if n > 3 else np.empty((0, 0))
    cov_fail = np.full(n_tr, -1, dtype=np.int64)
    b2 = blocks.lanes_empty((prm.window, L))
    b4 = blocks.lanes_empty((prm.window, L))
    s2 = blocks.lanes_empty((L,))
    s4 = blocks.lanes_empty((L,))
    x = blocks.lanes_empty((n, L))
    xn = blocks.lanes_empty((n, L))
    P = blocks.lanes_empty((n, n, L))
    FP = blocks.lanes_empty((n, n, L))
    Q = blocks.lanes_empty((n, n, L))
    PH = blocks.lanes_empty((n, L))
    phase = blocks.lanes_empty((L,))
    yr = blocks.lanes_empty((L,))
    yi = blocks.lanes_empty((L,))
    p2 = blocks.lanes_empty((L,))
    p4 = blocks.lanes_empty((L,))
    nu = blocks.lanes_empty((L,))
    R = blocks.lanes_empty((L,))
    sig = blocks.lanes_empty((L,))
    noi = blocks.lanes_empty((L,))
    trial = np.empty(L, dtype=np.int64)
    for a in range(n):
        for b in range(n):
            Q[a, b, :] = prm.Q[a, b]
    R[:] = prm.r_fixed
    for c0 in range(0, n_tr, L):
        m = blocks.lane_trials(c0, n_tr, trial)  # trials of this block written out
        for ln in range(L):
            t = trial[ln]
            for a in range(n):
                x[a, ln] = prm.x0[t, a]
                for b in range(n):
                    P[a, b, ln] = prm.P0[a, b]
        b2[:, :] = 0.0
        b4[:, :] = 0.0
        s2[:] = 0.0
        s4[:] = 0.0
        count = 0
        pos = 0
        for i in range(k):
            if i > 0:
                blocks.sparse_predict_lanes(x, P, xn, FP, Q, rows, cols, vals, nnz)
            ph = lane_splat(0.0)
            for a in range(n):
                ph = ph + prm.H[a] * lane_load(x, a * L)
            lane_store(phase, 0, ph)
            blocks.prompt_discriminator_lanes(y, trial, i, phase, False, yr, yi, nu)
            if prm.adaptive:
                pos, count = blocks.m2m4_lanes(b2, b4, pos, s2, s4, count, yr, yi, p2, p4, prm.min_epochs, prm.prior_signal, prm.prior_noise,
                                               prm.floor_fraction, sig, noi)
                for ln in range(L):
                    R[ln] = blocks.atan_variance(blocks.cn0_from_powers(sig[ln], noi[ln], prm.ts), prm.ts)
                for ln in range(m):
                    r_out[trial[ln], i] = R[ln]
            blocks.scalar_update_lanes(x, P, PH, prm.H, R, nu)
            for ln in range(m):
                t = trial[ln]
                if cov_fail[t] < 0 and not blocks.covariance_ok(P[0, 0, ln], P[1, 1, ln], P[0, 1, ln]):
                    cov_fail[t] = i
                out[t, i] = x[0, ln]
                if n > 3:
                    tot[t, i] = x[0, ln] + x[3, ln]
    return out, r_out, tot, cov_fail


@dataclass
class DiscriminatorKF(Tracker):
    ts: float
    q_jerk: float
    nominal_cn0_hz: float
    p0_diag: tuple[float, float, float]
    adaptive_r: bool = False
    cn0_window: int = 50
    ar_coefs: np.ndarray | None = None
    ar_sigma2: float = 0.0
    ar_p0: float = 0.01
    amplitude: float = 1.0

    PROVIDES = frozenset({"R", "total_phase", "cov_fail_epoch"})

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """F, Q and H (row) of the filter."""
        f_d = dynamics_F(self.ts)
        q_d = dynamics_Q(self.q_jerk, self.ts)
        if self.ar_coefs is None:
            return f_d, q_d, np.array([1.0, 0.0, 0.0])
        p = len(self.ar_coefs)
        n = 3 + p
        F = np.zeros((n, n))
        Q = np.zeros((n, n))
        F[:3, :3], Q[:3, :3] = f_d, q_d
        F[3:, 3:] = companion(np.asarray(self.ar_coefs, dtype=float), p)
        Q[3, 3] = self.ar_sigma2
        H = np.zeros(n)
        H[0] = H[3] = 1.0
        return F, Q, H

    def _p0(self, n: int) -> np.ndarray:
        p0 = np.zeros((n, n))
        p0[np.arange(3), np.arange(3)] = self.p0_diag
        if n > 3:
            p0[np.arange(3, n), np.arange(3, n)] = self.ar_p0
        return p0

    @property
    def nominal_noise(self) -> float:
        """Noise power at the nominal C/N0 (the M2M4 prior)."""
        return self.amplitude**2 / (self.nominal_cn0_hz * self.ts)

    def params(self, init: TrackInit) -> KfParams:
        F, Q, H = self.matrices()
        n = F.shape[0]
        return KfParams(
            initial_state(init, n), self._p0(n), Q, H, bool(self.adaptive_r), float(blocks.atan_variance(self.nominal_cn0_hz, self.ts)),
            int(self.cn0_window), float(self.amplitude**2), float(self.nominal_noise), float(self.ts), M2M4_MIN_EPOCHS, M2M4_FLOOR,
            *blocks.nonzeros(F),
        )

    def run(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """Compiled loop (:func:`kf_kernel`)."""
        out, r_out, tot, cov_fail = kf_kernel(np.ascontiguousarray(y, dtype=complex), self.params(init))
        return TrackOutput(theta_d=out, extras=self._extras(r_out, tot, cov_fail))

    def request(self, wanted: Collection[str] = ()) -> frozenset[str]:
        """The outputs of :meth:`_extras`, whatever is wanted."""
        return frozenset({"cov_fail_epoch"} | ({"R"} if self.adaptive_r else set()) | ({"total_phase"} if self.ar_coefs is not None else set()))

    def _extras(self, r_out: np.ndarray, total: np.ndarray, cov_fail: np.ndarray) -> dict[str, np.ndarray]:
        """``R`` (adaptive), with AR states ``total_phase`` = theta_d + theta_s estimate (``H x``), and
        ``cov_fail_epoch`` (trials,): first epoch whose updated P fails :func:`.blocks.covariance_ok` (-1 none)."""
        extras = {"R": r_out, "cov_fail_epoch": cov_fail} if self.adaptive_r else {"cov_fail_epoch": cov_fail}
        if self.ar_coefs is not None:
            extras["total_phase"] = total
        return extras

    def reference(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """Textbook Kalman filter in numpy, one time loop vectorised over trials.

        ``x = F x``, ``P = F P F^T + Q``; ``S = H P H^T + R``, ``K = P H^T S^-1``,
        ``x += K nu`` with ``nu`` the discriminator on ``H x``, ``P = (I - K H) P``.
        """
        n_tr, k = y.shape
        F, Q, H = self.matrices()
        n = F.shape[0]
        H = H[None, :]  # (1, n)
        eye = np.eye(n)
        x = initial_state(init, n)[:, :, None]  # (trials, n, 1)
        P = np.broadcast_to(self._p0(n), (n_tr, n, n)).copy()
        cn0 = StreamingM2M4(n_tr, self.cn0_window, prior_signal=self.amplitude**2, prior_noise=self.nominal_noise, min_epochs=M2M4_MIN_EPOCHS, floor_fraction=M2M4_FLOOR)
        out = np.empty((n_tr, k))
        r_out = np.empty((n_tr, k))
        tot = np.empty((n_tr, k))
        cov_fail = np.full(n_tr, -1, dtype=np.int64)
        for i in range(k):
            if i > 0:
                x = F @ x
                P = F @ P @ F.T + Q
            yi = y[:, i]
            if self.adaptive_r:
                sig, noi = cn0.update(yi)
                R = atan_variance(cn0_from_powers(sig, noi, self.ts), self.ts)
            else:
                R = np.full(n_tr, atan_variance(self.nominal_cn0_hz, self.ts))
            r_out[:, i] = R
            nu = atan2_discriminator(yi, (H @ x)[:, 0, 0])
            S = H @ P @ H.T + R[:, None, None]  # (trials, 1, 1)
            K = P @ H.T @ np.linalg.inv(S)  # (trials, n, 1)
            x = x + K * nu[:, None, None]
            P = (eye - K @ H) @ P
            cov_fail[(cov_fail < 0) & ~blocks.covariance_ok_ufunc(P[:, 0, 0], P[:, 1, 1], P[:, 0, 1])] = i
            out[:, i] = x[:, 0, 0]
            tot[:, i] = (H @ x)[:, 0, 0]
        return TrackOutput(theta_d=out, extras=self._extras(r_out, tot, cov_fail))

    @classmethod
    def _common(cls, spec: Mapping[str, Any], context: TrackerContext, adaptive: bool) -> dict[str, Any]:
        return dict(
            ts=context.ts, q_jerk=spec_q_jerk(spec, context), nominal_cn0_hz=context.cn0_hz, p0_diag=spec_p0(context),
            adaptive_r=adaptive, cn0_window=int(context.tracking["cn0_window"]), amplitude=float(context.tracking["amplitude"]),
        )


#: tracking keys read by ``_common`` (cn0_dbhz through ``context.cn0_hz``)
KF_TRACKING_KEYS = ("amplitude", "cn0_dbhz", "cn0_window", "p0_diag", "q_jerk_hz2_s3")


@register("kf")
class KF(DiscriminatorKF):
    """KF: fixed R = eq. (12) at the nominal C/N0."""

    ADAPTIVE_R = False
    TRACKING_KEYS = KF_TRACKING_KEYS
    SPEC_OVERRIDES = {"q_jerk_hz2_s3": "q_jerk_hz2_s3"}
    SCHEMA = {"q_jerk_hz2_s3": Q_JERK_SCHEMA}

    @classmethod
    def from_spec(cls, spec: Mapping[str, Any], context: TrackerContext) -> KF:
        return cls(**cls._common(spec, context, adaptive=cls.ADAPTIVE_R))

    @classmethod
    def label(cls, name: str, spec: Mapping[str, Any]) -> str:
        return compose(cls.__name__, q_qualifier(spec))


@register("akf")
class AKF(KF):
    """AKF: the KF with R_k = eq. (12) at the M2M4 C/N0 estimate."""

    ADAPTIVE_R = True


@register("akf_ar")
class AKFAR(DiscriminatorKF):
    """AKF-AR: the AKF with the AR(p) scintillation phase in the state."""

    TRACKING_KEYS = (*KF_TRACKING_KEYS, "theta_s_p0")
    SPEC_OVERRIDES = {"q_jerk_hz2_s3": "q_jerk_hz2_s3"}
    SCHEMA = {"q_jerk_hz2_s3": Q_JERK_SCHEMA, "design": DESIGN_SCHEMA, "phase_order": PHASE_ORDER_SCHEMA}

    @classmethod
    def from_spec(cls, spec: Mapping[str, Any], context: TrackerContext) -> AKFAR:
        ar = design_ar(spec, context)
        tracker = cls(**cls._common(spec, context, adaptive=True), ar_coefs=ar.phase.coefs, ar_sigma2=ar.phase.sigma2, ar_p0=float(context.tracking["theta_s_p0"]))
        tracker.design_point = design_point(ar)  # (S4, tau0) of the table point used (.design); None: no scintillation model
        return tracker

    @staticmethod
    def label(name: str, spec: Mapping[str, Any]) -> str:
        quals = ["no scint. model"] if spec.get("design") == "none" else []
        s4 = explicit_design_s4(spec)
        return compose("AKF-AR", quals + q_qualifier(spec), f", AR fit at S4 = {s4:g}" if s4 is not None else "")
