"""AEKF-AR: adaptive EKF on [I, Q] with AR scintillation phase and amplitude; type ``aekf_ar``.

Vila-Valls 2018, Sec. IV-B and V-B.  State (eq. 11)
``x = [theta_d, f_d, f_r, theta_s,k .. theta_s,k-p+1, rho_s,k .. rho_s,k-q+1]``,
transition ``F = blkdiag(F_d, F_p(beta), F_a(gamma))`` plus ``kappa`` on the
``rho_s,k`` row, ``Q = blkdiag(Q_d, sigma_eta_theta^2, 0.., sigma_eta_rho^2, 0..)``.
Measurement (eq. 13) ``h(x) = A rho_s [cos(theta_d + theta_s), sin(theta_d + theta_s)]``
with the Jacobian of eq. (14) and ``R = s2/2 I_2``, ``s2`` the M2M4 noise-power
estimate on the incoming prompts.

Adaptation (Sec. V-B): an on-line S4 estimate (noise-corrected intensity
moments over a sliding window, :mod:`scintrack.estimators.s4`) selects, per
trial, the nearest of a list of AR models (:class:`~scintrack.models.ar.ScintillationAR`,
"adaptation points", each an (S4, tau0) entry of the AR look-up table with the
orders of Table I).  All sets share the largest state (p = q = 3), with unused
lags set to zero, so switching SSM #1-#4 is a change of F_k and Q_k only (the
paper's single-filter architecture).  A new set is adopted only after it has
been the nearest one for ``adapt_hold`` consecutive epochs (a hold against
switching back and forth on estimator noise; the paper gives no rule).
A "not estimable" S4 (NaN, :func:`.blocks.s4_corrected`: signal power
unresolved or S4 >= 2) is recorded as NaN in ``s4_hat`` but never chooses a
set: the nearest set is that of the last estimable S4 of the trial (the
initial set's S4 until the first; a lane-wise select,
:func:`.simd.select_less`): without it a non-resolvable signal would give
S4 up to ~1e12 (the 1e-12 floor of the signal power) and choose the
largest-S4 set.
Non-adaptive use: a single parameter set (``design``, :mod:`.design`).

Not in the paper (an isolating option, off by default): ``fold_mirror``.
The I/Q measurement is invariant under ``(rho_s, theta_s) -> (-rho_s,
theta_s + pi)`` and nothing in eqs. (9)-(14) keeps ``rho_s > 0``; in deep
fades the EKF crosses to that mirror solution, so its theta_s is off by pi
(and its theta_d, after the dynamics absorb it, too).  With ``fold_mirror``
a negative ``rho_s,k`` after the update is mapped back: every amplitude lag
changes sign, every theta_s lag gains pi, and ``P -> J P J`` with ``J`` the
matching sign matrix.  The I/Q prediction is unchanged by the fold.

Receiver fixes (options, off by default; not in the paper; an ablation study):

* ``noise_estimate: reference``: the noise power of the on-line S4 correction
  (Sec. V-B) comes from a correlator that carries no signal (a far code
  offset, as receivers have), the mean of ``|n_ref|^2`` over the noise
  window, instead of the M2M4 split of the prompts, which is biased high
  under fading (the M2M4 assumes a constant amplitude in its window).  R of
  the update keeps the M2M4 value.  The reference samples come with
  :class:`~.base.TrackInit` (``noise_reference``).
* ``amplitude_floor: r``: a constrained update that keeps the amplitude
  positive by projection, ``rho_s,k <- max(rho_s,k, r)`` after each update
  (no pi jump of theta_s, unlike ``fold_mirror``).

``static: true`` (Sec. VI-E2) fixes the dynamics block at zero (known, no
process noise): the dynamics-free scintillation tracking of the traces.

The kernel (:func:`aekf_kernel`) is made of :mod:`.blocks` (structured
predict, M2M4, closed-form I/Q update, fold, sliding S4, nearest point) and
runs ``blocks.LANES`` (32) trials side by side: every state array carries the
trial on its last axis and each matrix entry of the 32 trials is one SIMD
vector (``Lanes``).  The predict uses the structure of F (the lag shifts
of the companion blocks are copies; only rows 0, 1, 3, ir of F P and columns
0-3, ir of (F P) F^T take arithmetic; :func:`.blocks.ar_predict`); ``P`` is
computed in full (both triangles), as the reference does.  No operation is
fused or reassociated (no fast-math) and no lane reads another, so a trial's
result does not depend on its batch; a last block with fewer trials computes
copies of its last trial (discarded), so a block costs the same for 1 or 32
trials.  Tests (``tests/test_lane_kernels.py``): the kernel against
:meth:`AEKFAR.reference` (adaptive, ``fold_mirror``, ``amplitude_floor``,
``noise_estimate: reference``, other state orders, static), the same bits in
batches of 1, 31, 32, 33 and 40 trials, NaN and inf prompts.

Divergence guard: every :data:`COV_CHECK_EVERY` (16) epochs, from epoch 0,
the kernel tests the (theta_d, f_d) block of every lane's updated P with
:func:`.blocks.covariance_ok` (read-only) and records the first failing
checked epoch per trial, ``extras["cov_fail_epoch"]`` (-1 none; always
returned; the reference checks on the same schedule).  Checked at every
epoch the test costs 6-9 % of the kernel's rate (256 trials x 5000 epochs,
adaptive); every 16 epochs it is within the noise.  The flag can so lag the
first failure by up to 15 epochs; a failure that makes the state non-finite is caught at its exact
epoch by the guard's non-finite test anyway (:mod:`scintrack.experiments.guards`).

:meth:`AEKFAR.reference` is the textbook EKF with the 2 x n Jacobian of
eq. (14) built explicitly and S inverted by ``numpy.linalg``.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from ..estimators.cn0 import M2M4_FLOOR, M2M4_MIN_EPOCHS, StreamingM2M4
from ..estimators.s4 import StreamingS4
from ..estimators.window import SlidingSums
from ..models.ar import ScintillationAR
from ..models.lut import scintillation_ar
from ..simd.lanes import lane_load, lane_store
from . import blocks
from .base import (
    DESIGN_SCHEMA,
    PHASE_ORDER_SCHEMA,
    Q_JERK_SCHEMA,
    Tracker,
    TrackerContext,
    TrackInit,
    TrackOutput,
    companion,
    dynamics_F,
    dynamics_Q,
    initial_state,
    spec_p0,
    spec_q_jerk,
)
from .design import compose, design_ar, explicit_design_s4, q_qualifier
from .registry import register

RECORDABLE = ("theta_s", "rho_s", "s4_hat", "ar_set")
#: period [epochs] of the covariance test of the divergence guard (module docstring)
COV_CHECK_EVERY = 16


class AekfParams(NamedTuple):
    """Everything :func:`aekf_kernel` needs besides the prompts."""

    x0: np.ndarray  # (trials, n) initial state
    p0: np.ndarray  # (n,) initial variances (P0 diagonal)
    coef_tab: np.ndarray  # (sets, C_AR + p + q) F, Q and kappa of every set (blocks.ar_coefficients)
    s4_points: np.ndarray  # (sets,) S4 of each set
    adaptive: bool
    initial_set: int
    A: float  # nominal amplitude
    nominal_noise: float  # noise power before the M2M4 window has M2M4_MIN_EPOCHS
    noise_window: int
    s4_window: int
    s4_min_epochs: int
    adapt_hold: int
    p: int  # theta_s lags in the state
    q: int  # rho_s lags in the state
    record: bool
    floor_fraction: float
    fold_mirror: bool
    ref_noise: bool  # S4 noise power from the reference (signal-free) correlator
    nref: np.ndarray  # (trials, epochs) reference correlator samples, or (0, 0)
    rho_floor: float  # amplitude floor of the constrained update (<= 0: off)


@njit(cache=True)
def aekf_kernel(y, prm):
    """The AEKF-AR, ``blocks.LANES`` trials at a time (trial on the last axis: SIMD over trials).

    Per epoch and lane: predict, M2M4, I/Q update, fold, floor, symmetrisation,
    S4 switch; no lane reads another, so every trial's result is the one it has
    alone, bit for bit.  Ring buffers
    are (window, LANES) with a position and count common to the lanes (every
    lane pushes once per epoch).
    """
    L = blocks.LANES
    n_tr, k = y.shape
    p, q = prm.p, prm.q
    n = 3 + p + q
    ir = 3 + p
    nc = prm.coef_tab.shape[1]
    out = np.empty((n_tr, k))
    cov_fail = np.full(n_tr, -1, dtype=np.int64)  # first epoch failing blocks.covariance_ok, per trial
    if prm.record:
        rec_ts = np.empty((n_tr, k))
        rec_rho = np.empty((n_tr, k))
        rec_s4 = np.empty((n_tr, k))
        rec_set = np.empty((n_tr, k))
    else:
        rec_ts = np.empty((0, 0))
        rec_rho = np.empty((0, 0))
        rec_s4 = np.empty((0, 0))
        rec_set = np.empty((0, 0))
    # ring buffers (one per lane) and their running sums; positions and counts are common to the lanes
    nb2 = blocks.lanes_empty((prm.noise_window, L))
    nb4 = blocks.lanes_empty((prm.noise_window, L))
    sb1 = blocks.lanes_empty((prm.s4_window, L))
    sb2 = blocks.lanes_empty((prm.s4_window, L))
    rb1 = blocks.lanes_empty((prm.noise_window, L))
    rb2 = blocks.lanes_empty((prm.noise_window, L))
    ns2 = blocks.lanes_empty((L,))
    ns4 = blocks.lanes_empty((L,))
    ss1 = blocks.lanes_empty((L,))
    ss2 = blocks.lanes_empty((L,))
    rs1 = blocks.lanes_empty((L,))
    rs2 = blocks.lanes_empty((L,))
    x = blocks.lanes_empty((n, L))
    xn = blocks.lanes_empty((n, L))
    P = blocks.lanes_empty((n, n, L))
    Pn = blocks.lanes_empty((n, n, L))
    G = blocks.lanes_empty((4, n, L))
    ph0 = blocks.lanes_empty((n, L))
    ph1 = blocks.lanes_empty((n, L))
    co = blocks.lanes_empty((nc, L))
    r = blocks.lanes_empty((L,))
    yr = blocks.lanes_empty((L,))
    yi = blocks.lanes_empty((L,))
    p2 = blocks.lanes_empty((L,))
    p4 = blocks.lanes_empty((L,))
    r2 = blocks.lanes_empty((L,))
    r4 = blocks.lanes_empty((L,))
    s2 = blocks.lanes_empty((L,))
    trial = np.empty(L, dtype=np.int64)
    idx = np.empty(L, dtype=np.int64)
    candidate = np.empty(L, dtype=np.int64)
    held = np.empty(L, dtype=np.int64)
    s4_hat = blocks.lanes_empty((L,))
    s4_use = blocks.lanes_empty((L,))  # the last estimable S4 (the prior until the first): what chooses the set
    nearest = blocks.lanes_empty((L,))
    for c0 in range(0, n_tr, L):
        blocks.lane_trials(c0, n_tr, trial)  # a short last block repeats its last trial (not written)
        for ln in range(L):
            t = trial[ln]
            for a in range(n):
                x[a, ln] = prm.x0[t, a]
                for b in range(n):
                    P[a, b, ln] = 0.0
                P[a, a, ln] = prm.p0[a]
            for j in range(nc):
                co[j, ln] = prm.coef_tab[prm.initial_set, j]
            idx[ln] = prm.initial_set
            candidate[ln] = prm.initial_set
            held[ln] = 0
            s4_hat[ln] = prm.s4_points[prm.initial_set]
            s4_use[ln] = s4_hat[ln]
        nb2[:, :] = 0.0
        nb4[:, :] = 0.0
        sb1[:, :] = 0.0
        sb2[:, :] = 0.0
        rb1[:, :] = 0.0
        rb2[:, :] = 0.0
        ns2[:] = 0.0
        ns4[:] = 0.0
        ss1[:] = 0.0
        ss2[:] = 0.0
        rs1[:] = 0.0
        rs2[:] = 0.0
        ncount = 0
        npos = 0
        scount = 0
        spos = 0
        rcount = 0
        rpos = 0
        for i in range(k):
            if i > 0:
                blocks.ar_predict(x, P, xn, Pn, G, co, p, q)
                x, xn = xn, x
                P, Pn = Pn, P
            # M2M4 noise power over the last noise_window epochs
            for ln in range(L):
                v = y[trial[ln], i]
                yr[ln], yi[ln] = v.real, v.imag
                p2[ln] = yr[ln] * yr[ln] + yi[ln] * yi[ln]
                p4[ln] = p2[ln] * p2[ln]
            npos, ncount = blocks.window_push_lanes(nb2, nb4, npos, ns2, ns4, ncount, p2, p4)
            if ncount < M2M4_MIN_EPOCHS:
                s2[:] = prm.nominal_noise
            else:
                _, s2v = blocks.m2m4_split(lane_load(ns2, 0) / ncount, lane_load(ns4, 0) / ncount, prm.floor_fraction)
                lane_store(s2, 0, s2v)
            lane_store(r, 0, 0.5 * lane_load(s2, 0))
            blocks.iq_update(x, P, ph0, ph1, prm.A, ir, r, yr, yi)
            for ln in range(L):
                if prm.fold_mirror and x[ir, ln] < 0.0:
                    blocks.fold_mirror(x[:, ln], P[:, :, ln], ir)
                if prm.rho_floor > 0.0 and x[ir, ln] < prm.rho_floor:
                    x[ir, ln] = prm.rho_floor
            if i % 64 == 63:
                for ln in range(L):
                    blocks.symmetrise(P[:, :, ln])
            if prm.adaptive:
                spos, scount = blocks.window_push_lanes(sb1, sb2, spos, ss1, ss2, scount, p2, p4)
                if prm.ref_noise:
                    for ln in range(L):
                        w = prm.nref[trial[ln], i]
                        r2[ln] = w.real**2 + w.imag**2
                        r4[ln] = r2[ln] * r2[ln]
                    rpos, rcount = blocks.window_push_lanes(rb1, rb2, rpos, rs1, rs2, rcount, r2, r4)
                s2_s4 = lane_load(rs1, 0) / rcount if prm.ref_noise else lane_load(s2, 0)
                if scount >= prm.s4_min_epochs:
                    mean, var = blocks.window_mean_var(lane_load(ss1, 0), lane_load(ss2, 0), scount)
                    est = blocks.s4_corrected(mean, var, s2_s4)
                    lane_store(s4_hat, 0, est)  # recorded as is: NaN = not estimable
                    lane_store(s4_use, 0, blocks.select_less(est, np.inf, est, lane_load(s4_use, 0)))  # NaN holds
                lane_store(nearest, 0, blocks.nearest_index_lanes(lane_load(s4_use, 0), prm.s4_points))
                for ln in range(L):
                    best = int(nearest[ln])
                    held[ln] = held[ln] + 1 if best == candidate[ln] else 0
                    candidate[ln] = best
                    if held[ln] >= prm.adapt_hold and idx[ln] != best:
                        idx[ln] = best
                        for j in range(nc):
                            co[j, ln] = prm.coef_tab[best, j]
            if i % COV_CHECK_EVERY == 0:
                for ln in range(min(L, n_tr - c0)):
                    t = trial[ln]
                    if cov_fail[t] < 0 and not blocks.covariance_ok(P[0, 0, ln], P[1, 1, ln], P[0, 1, ln]):
                        cov_fail[t] = i
            for ln in range(min(L, n_tr - c0)):
                t = trial[ln]
                out[t, i] = x[0, ln]
                if prm.record:
                    rec_ts[t, i] = x[3, ln]
                    rec_rho[t, i] = x[ir, ln]
                    rec_s4[t, i] = s4_hat[ln]
                    rec_set[t, i] = idx[ln]
    return out, rec_ts, rec_rho, rec_s4, rec_set, cov_fail


@register("aekf_ar")
@dataclass
class AEKFAR(Tracker):
    ts: float
    q_jerk: float
    p0_diag: tuple[float, float, float]
    ar_sets: Sequence[ScintillationAR]
    p_state: int = 3
    q_state: int = 3
    adaptive: bool = False
    initial_set: int = 0
    amplitude: float = 1.0
    nominal_noise: float = 0.1
    noise_window: int = 100
    s4_window: int = 1000
    s4_min_epochs: int = 200
    adapt_hold: int = 200
    theta_s_p0: float = 0.01
    rho_p0: float = 0.05
    fold_mirror: bool = False
    noise_estimate: str = "m2m4"
    amplitude_floor: float = 0.0
    record: tuple[str, ...] = field(default_factory=tuple)

    PROVIDES = frozenset({*RECORDABLE, "cov_fail_epoch"})
    SPEC_OVERRIDES = {"q_jerk_hz2_s3": "q_jerk_hz2_s3"}
    TRACKING_KEYS = ("adapt_hold", "adaptation_points", "amplitude", "cn0_dbhz", "noise_window", "p0_diag", "q_jerk_hz2_s3", "rho_p0", "s4_min_epochs", "s4_window", "theta_s_p0")
    SCHEMA = {
        "adaptive": {"type": "boolean", "description": "switch between tracking.adaptation_points on the on-line S4 (Sec. V-B)"},
        "design": DESIGN_SCHEMA,
        "phase_order": PHASE_ORDER_SCHEMA,
        "state": {"type": "array", "minItems": 2, "maxItems": 2, "items": {"type": "integer", "minimum": 1, "maximum": 3}, "description": "[p, q] lags held in the state"},
        "q_jerk_hz2_s3": Q_JERK_SCHEMA,
        "static": {"type": "boolean", "description": "dynamics known to be zero (Sec. VI-E2)"},
        "fold_mirror": {"type": "boolean", "description": "map a negative rho_s back to the positive solution (isolating option)"},
        "noise_estimate": {"enum": ["m2m4", "reference"], "description": "noise power of the on-line S4: M2M4 of the prompts (paper) or a signal-free reference correlator"},
        "amplitude_floor": {"type": "number", "minimum": 0, "maximum": 1, "description": "constrained update rho_s >= this (0: off)"},
    }

    def __post_init__(self):
        for s in self.ar_sets:
            if s.phase.order > self.p_state or s.amplitude.order > self.q_state:
                raise ValueError(f"AR set {s.label!r} has more lags than the state holds (p={self.p_state}, q={self.q_state})")
        unknown = set(self.record) - set(RECORDABLE)
        if unknown:
            raise ValueError(f"cannot record {sorted(unknown)} (recordable: {', '.join(RECORDABLE)})")

    # --- config ---------------------------------------------------------------

    @classmethod
    def from_spec(cls, spec: Mapping[str, Any], context: TrackerContext) -> AEKFAR:
        tr = context.tracking
        amp = float(tr["amplitude"])
        q, p0 = spec_q_jerk(spec, context), spec_p0(context)
        if spec.get("static", False):
            q, p0 = 0.0, (0.0, 0.0, 0.0)
        p_state, q_state = spec.get("state", [3, 3])
        adaptive = bool(spec.get("adaptive", False))
        if adaptive:
            if context.lut is None:
                raise ValueError("adaptive: true needs the AR look-up table")
            sets = [ScintillationAR.no_scintillation()] + [scintillation_ar(context.lut, float(s4), float(tau0)) for s4, tau0 in tr["adaptation_points"]]
        else:
            sets = [design_ar(spec, context)]
        return cls(
            ts=context.ts, q_jerk=q, p0_diag=p0, ar_sets=sets, p_state=int(p_state), q_state=int(q_state), adaptive=adaptive,
            initial_set=0, amplitude=amp, nominal_noise=amp**2 / (context.cn0_hz * context.ts),
            noise_window=int(tr["noise_window"]), s4_window=int(tr["s4_window"]), s4_min_epochs=int(tr["s4_min_epochs"]),
            adapt_hold=int(tr["adapt_hold"]), theta_s_p0=float(tr["theta_s_p0"]), rho_p0=float(tr["rho_p0"]),
            fold_mirror=bool(spec.get("fold_mirror", False)), noise_estimate=str(spec.get("noise_estimate", "m2m4")),
            amplitude_floor=float(spec.get("amplitude_floor", 0.0)),
        )

    @staticmethod
    def label(name: str, spec: Mapping[str, Any]) -> str:
        suffix = ", mirror folded" if spec.get("fold_mirror") else ""
        if spec.get("noise_estimate") == "reference":
            suffix += ", reference-noise S4"
        if spec.get("amplitude_floor"):
            suffix += f", rho >= {float(spec['amplitude_floor']):g}"
        s4 = explicit_design_s4(spec)
        if s4 is not None:
            return compose("AEKF-AR", q_qualifier(spec), f", AR fit at S4 = {s4:g}{suffix}")
        if "state" in spec:
            p, q = spec["state"]
            return compose(f"AEKF-AR{p}{q}", q_qualifier(spec), suffix)
        quals = []
        if spec.get("static"):
            quals.append("static")
        elif spec.get("adaptive"):
            pass
        elif spec.get("design", "scenario") == "none":
            quals.append("SSM #1")
        elif spec.get("design", "scenario") == "scenario":
            quals.append("fixed AR")
        return compose("AEKF-AR", quals + q_qualifier(spec), suffix)

    # --- model ------------------------------------------------------------------

    @property
    def n_state(self) -> int:
        return 3 + self.p_state + self.q_state

    @property
    def design_point(self) -> tuple[float, float] | None:
        """(S4, tau0) of the look-up-table point actually used (non-adaptive; None: adaptive or no scintillation model).

        Adaptive: the points of the sets are ``ar_sets[j].s4`` / ``tau0``.
        """
        from .design import design_point

        return None if self.adaptive else design_point(self.ar_sets[0])

    @property
    def needs_noise_reference(self) -> bool:
        return self.noise_estimate == "reference"

    def request(self, wanted: Collection[str] = ()) -> frozenset[str]:
        """Record from now on the state estimates of ``wanted`` (``s4_hat`` and ``ar_set``: adaptive only);
        ``cov_fail_epoch`` is always given."""
        have = RECORDABLE if self.adaptive else ("theta_s", "rho_s")
        self.record = tuple(name for name in wanted if name in have)
        return frozenset({*self.record, "cov_fail_epoch"})

    def tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """F, Q and kappa vectors of every AR set, stacked on a first axis."""
        n, p = self.n_state, self.p_state
        f_d, q_d = dynamics_F(self.ts), dynamics_Q(self.q_jerk, self.ts)
        F = np.zeros((len(self.ar_sets), n, n))
        Q = np.zeros_like(F)
        kap = np.zeros((len(self.ar_sets), n))
        for j, s in enumerate(self.ar_sets):
            F[j, :3, :3], Q[j, :3, :3] = f_d, q_d
            F[j, 3 : 3 + p, 3 : 3 + p] = companion(s.phase.coefs, p)
            F[j, 3 + p :, 3 + p :] = companion(s.amplitude.coefs, self.q_state)
            Q[j, 3, 3] = s.phase.sigma2
            Q[j, 3 + p, 3 + p] = s.amplitude.sigma2
            kap[j, 3 + p] = s.amplitude.const
        return F, Q, kap

    def _initial(self, init: TrackInit) -> tuple[np.ndarray, np.ndarray]:
        n, p = self.n_state, self.p_state
        x = initial_state(init, n)
        x[:, 3 + p :] = self.ar_sets[self.initial_set].rho_mean
        p0 = np.zeros(n)
        p0[:3] = self.p0_diag
        p0[3 : 3 + p] = self.theta_s_p0
        p0[3 + p :] = self.rho_p0
        return x, p0

    def _noise_reference(self, init: TrackInit) -> np.ndarray:
        if self.noise_estimate != "reference":
            return np.zeros((0, 0), dtype=complex)
        if init.noise_reference is None:
            raise ValueError("noise_estimate: reference needs the reference-correlator samples (TrackInit.noise_reference)")
        return np.ascontiguousarray(init.noise_reference, dtype=complex)

    def params(self, init: TrackInit) -> AekfParams:
        F_tab, Q_tab, kap_tab = self.tables()
        x, p0 = self._initial(init)
        return AekfParams(
            np.ascontiguousarray(x), p0, blocks.ar_coefficients(F_tab, Q_tab, kap_tab, self.p_state, self.q_state),
            np.array([s.s4 for s in self.ar_sets], dtype=float), bool(self.adaptive), int(self.initial_set),
            float(self.amplitude), float(self.nominal_noise), int(self.noise_window), int(self.s4_window), int(self.s4_min_epochs),
            int(self.adapt_hold), int(self.p_state), int(self.q_state), bool(self.record), M2M4_FLOOR, bool(self.fold_mirror),
            self.noise_estimate == "reference", self._noise_reference(init), float(self.amplitude_floor),
        )

    # --- filters ---------------------------------------------------------------------

    def run(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """Compiled loop (:func:`aekf_kernel`)."""
        out, th_s, rho, s4_hat, sets, cov_fail = aekf_kernel(np.ascontiguousarray(y, dtype=complex), self.params(init))
        available = {"theta_s": th_s, "rho_s": rho, "s4_hat": s4_hat, "ar_set": sets}
        return TrackOutput(theta_d=out, extras={**{k: available[k] for k in self.record}, "cov_fail_epoch": cov_fail})

    def reference(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """Textbook EKF in numpy, one time loop vectorised over trials.

        Predict ``x = F x + kappa``, ``P = F P F^T + Q`` (F, Q, kappa of each
        trial's current set); update on ``z = [I, Q]`` with ``h(x)`` of eq. (13)
        and its Jacobian H (2 x n, eq. 14) built explicitly:
        ``S = H P H^T + R``, ``K = P H^T S^-1`` (``numpy.linalg.inv``),
        ``x += K (z - h(x))``, ``P = (I - K H) P``; then the mirror fold, the
        periodic symmetrisation and the S4-driven switch as in the kernel.
        """
        n_tr, k = y.shape
        n, p = self.n_state, self.p_state
        ir = 3 + p  # index of rho_s,k
        A = self.amplitude
        F_tab, Q_tab, kap_tab = self.tables()
        s4_points = np.array([s.s4 for s in self.ar_sets])
        idx = np.full(n_tr, self.initial_set, dtype=int)
        x, p0 = self._initial(init)
        P = np.broadcast_to(np.diag(p0), (n_tr, n, n)).copy()
        eye = np.eye(n)
        noise = StreamingM2M4(n_tr, self.noise_window, prior_signal=A**2, prior_noise=self.nominal_noise, min_epochs=M2M4_MIN_EPOCHS, floor_fraction=M2M4_FLOOR)
        s4 = StreamingS4(n_tr, self.s4_window, prior=self.ar_sets[self.initial_set].s4, min_epochs=self.s4_min_epochs) if self.adaptive else None
        candidate = idx.copy()
        held = np.zeros(n_tr, dtype=int)
        out = np.empty((n_tr, k))
        rec = {name: np.empty((n_tr, k)) for name in self.record}
        cov_fail = np.full(n_tr, -1, dtype=np.int64)
        s4_hat = np.full(n_tr, self.ar_sets[self.initial_set].s4)
        nref = self._noise_reference(init)
        ref_power = SlidingSums(n_tr, 1, self.noise_window) if nref.size else None
        for i in range(k):
            if i > 0:
                Fi = F_tab[idx]
                x = np.einsum("tij,tj->ti", Fi, x) + kap_tab[idx]
                P = Fi @ P @ Fi.transpose(0, 2, 1) + Q_tab[idx]
            yi = y[:, i]
            _, s2 = noise.update(yi)
            R = 0.5 * s2[:, None, None] * np.eye(2)
            th = x[:, 0] + x[:, 3]
            rho = x[:, ir]
            h = A * rho[:, None] * np.stack([np.cos(th), np.sin(th)], axis=-1)  # eq. (13)
            H = np.zeros((n_tr, 2, n))  # eq. (14)
            H[:, 0, 0] = H[:, 0, 3] = -A * rho * np.sin(th)
            H[:, 1, 0] = H[:, 1, 3] = A * rho * np.cos(th)
            H[:, 0, ir] = A * np.cos(th)
            H[:, 1, ir] = A * np.sin(th)
            Ht = H.transpose(0, 2, 1)
            S = H @ P @ Ht + R
            K = P @ Ht @ np.linalg.inv(S)
            nu = np.stack([yi.real, yi.imag], axis=-1) - h
            x = x + (K @ nu[:, :, None])[:, :, 0]
            P = (eye - K @ H) @ P
            if self.fold_mirror:
                neg = x[:, ir] < 0.0
                if neg.any():
                    sign = np.where(np.arange(n) >= ir, -1.0, 1.0)
                    x[neg, 3:ir] += np.pi
                    x[neg] = x[neg] * sign
                    P[neg] = P[neg] * sign[None, :, None] * sign[None, None, :]
            if self.amplitude_floor > 0.0:
                x[:, ir] = np.maximum(x[:, ir], self.amplitude_floor)
            if i % 64 == 63:
                P = 0.5 * (P + P.transpose(0, 2, 1))
            if s4 is not None:
                s2_s4 = s2
                if ref_power is not None:
                    sums, count = ref_power.push((np.abs(nref[:, i]) ** 2)[:, None])
                    s2_s4 = sums[:, 0] / count
                s4_hat = s4.update(yi, s2_s4)
                nearest = np.argmin(np.abs(s4.held[:, None] - s4_points[None, :]), axis=1)  # a NaN estimate holds
                held = np.where(nearest == candidate, held + 1, 0)
                candidate = nearest
                idx = np.where(held >= self.adapt_hold, candidate, idx)
            out[:, i] = x[:, 0]
            if i % COV_CHECK_EVERY == 0:  # the kernel's schedule
                cov_fail[(cov_fail < 0) & ~blocks.covariance_ok_ufunc(P[:, 0, 0], P[:, 1, 1], P[:, 0, 1])] = i
            for name, value in (("theta_s", x[:, 3]), ("rho_s", x[:, ir]), ("s4_hat", s4_hat), ("ar_set", idx)):
                if name in rec:
                    rec[name][:, i] = value
        return TrackOutput(theta_d=out, extras={**rec, "cov_fail_epoch": cov_fail})
