"""AEKF-AR: adaptive EKF on [I, Q] with AR scintillation phase and amplitude.

Vila-Valls 2018, Sec. IV-B and V-B.  State (eq. 11)
``x = [theta_d, f_d, f_r, theta_s,k .. theta_s,k-p+1, rho_s,k .. rho_s,k-q+1]``,
transition ``F = blkdiag(F_d, F_p(beta), F_a(gamma))`` plus ``kappa`` on the
``rho_s,k`` row, ``Q = blkdiag(Q_d, sigma_eta_theta^2, 0.., sigma_eta_rho^2, 0..)``.
Measurement (eq. 13) ``h(x) = A rho_s [cos(theta_d + theta_s), sin(theta_d + theta_s)]``
with the Jacobian of eq. (14) and ``R = s2/2 I_2``, ``s2`` the M2M4 noise-power
estimate on the incoming prompts.

Adaptation (Sec. V-B): an on-line S4 estimate (noise-corrected intensity
moments over a sliding window, :mod:`scintrack.estimators.s4`) selects, per
trial, the nearest of a list of AR parameter sets ("adaptation
points", each an (S4, tau0) entry of the AR look-up table with the orders of
Table I).  All sets share the largest state (p = q = 3), with unused lags set to
zero, so switching SSM #1-#4 is a change of F_k and Q_k only (the paper's
single-filter architecture).  A new set is adopted only after it has been the
nearest one for ``adapt_hold`` consecutive epochs (a hold against switching
back and forth on estimator noise; the paper gives no rule).  Non-adaptive use: a single parameter set.

Not in the paper (an isolating option, off by default): ``fold_mirror``.
The I/Q measurement is invariant under ``(rho_s, theta_s) -> (-rho_s,
theta_s + pi)`` and nothing in eqs. (9)-(14) keeps ``rho_s > 0``; in deep
fades the EKF crosses to that mirror solution, so its theta_s is off by pi
(and its theta_d, after the dynamics absorb it, too).  With ``fold_mirror``
a negative ``rho_s,k`` after the update is mapped back: every amplitude lag
changes sign, every theta_s lag gains pi, and ``P -> J P J`` with ``J`` the
matching sign matrix.  The I/Q prediction is unchanged by the fold.

The measurement update exploits that H has non-zero entries only in the
columns of theta_d, theta_s,k and rho_s,k: ``P H^T`` is two weighted column
sums and the 2x2 innovation covariance is inverted in closed form.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..estimators.cn0 import StreamingM2M4
from ..estimators.s4 import StreamingS4
from .base import TrackInit, TrackOutput, companion, dynamics_F, dynamics_Q


@dataclass(frozen=True)
class ArSet:
    """One SSM parameterisation: AR(p) phase and AR(q) amplitude (eqs. 9-10)."""

    beta: np.ndarray
    gamma: np.ndarray
    kappa: float
    sigma2_theta: float
    sigma2_rho: float
    s4: float = 0.0
    label: str = ""

    @staticmethod
    def no_scintillation() -> ArSet:
        """SSM #1 as in Case I: gamma_1 = 1, everything else 0."""
        return ArSet(beta=np.zeros(1), gamma=np.array([1.0]), kappa=0.0, sigma2_theta=0.0, sigma2_rho=0.0, s4=0.0, label="none")

    @property
    def rho_mean(self) -> float:
        denom = 1.0 - float(np.sum(self.gamma))
        return self.kappa / denom if abs(denom) > 1e-9 else 1.0


@dataclass
class AEKFAR:
    ts: float
    q_jerk: float
    p0_diag: tuple[float, float, float]
    ar_sets: Sequence[ArSet]
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
    record: tuple[str, ...] = field(default_factory=tuple)

    def __post_init__(self):
        for s in self.ar_sets:
            if len(s.beta) > self.p_state or len(s.gamma) > self.q_state:
                raise ValueError(f"AR set {s.label!r} has more lags than the state holds (p={self.p_state}, q={self.q_state})")

    @property
    def n_state(self) -> int:
        return 3 + self.p_state + self.q_state

    def tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """F, Q and kappa vectors of every AR set, stacked on a first axis."""
        n, p = self.n_state, self.p_state
        f_d, q_d = dynamics_F(self.ts), dynamics_Q(self.q_jerk, self.ts)
        F = np.zeros((len(self.ar_sets), n, n))
        Q = np.zeros_like(F)
        kap = np.zeros((len(self.ar_sets), n))
        for j, s in enumerate(self.ar_sets):
            F[j, :3, :3], Q[j, :3, :3] = f_d, q_d
            F[j, 3 : 3 + p, 3 : 3 + p] = companion(s.beta, p)
            F[j, 3 + p :, 3 + p :] = companion(s.gamma, self.q_state)
            Q[j, 3, 3] = s.sigma2_theta
            Q[j, 3 + p, 3 + p] = s.sigma2_rho
            kap[j, 3 + p] = s.kappa
        return F, Q, kap

    def _initial(self, init: TrackInit, n_tr: int) -> tuple[np.ndarray, np.ndarray]:
        n, p = self.n_state, self.p_state
        x = np.zeros((n_tr, n))
        x[:, 0], x[:, 1], x[:, 2] = init.phase, init.doppler_hz, init.rate_hz_s
        x[:, 3 + p :] = self.ar_sets[self.initial_set].rho_mean
        p0 = np.zeros(n)
        p0[:3] = self.p0_diag
        p0[3 : 3 + p] = self.theta_s_p0
        p0[3 + p :] = self.rho_p0
        return x, p0

    def run(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """Compiled loop (:func:`scintrack.trackers.kernels.aekf_kernel`)."""
        from .kernels import aekf_kernel, nonzeros

        F_tab, Q_tab, kap_tab = self.tables()
        x, p0 = self._initial(init, y.shape[0])
        record = bool(self.record)
        out, th_s, rho, s4_hat, sets = aekf_kernel(
            np.ascontiguousarray(y, dtype=complex), x, p0, F_tab, Q_tab, kap_tab,
            np.array([s.s4 for s in self.ar_sets], dtype=float), bool(self.adaptive), int(self.initial_set),
            float(self.amplitude), float(self.nominal_noise), int(self.noise_window), int(self.s4_window),
            int(self.s4_min_epochs), int(self.adapt_hold), 3 + self.p_state, record, 1e-3, *nonzeros(F_tab),
            bool(self.fold_mirror),
        )
        available = {"theta_s": th_s, "rho_s": rho, "s4_hat": s4_hat, "ar_set": sets}
        return TrackOutput(theta_d=out, extras={k: available[k] for k in self.record})

    def run_numpy(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """Vectorised numpy reference of the same filter."""
        n_tr, k = y.shape
        n, p = self.n_state, self.p_state
        ir = 3 + p  # index of rho_s,k
        A = self.amplitude
        F_tab, Q_tab, kap_tab = self.tables()
        s4_points = np.array([s.s4 for s in self.ar_sets])
        idx = np.full(n_tr, self.initial_set, dtype=int)

        x, p0 = self._initial(init, n_tr)
        P = np.broadcast_to(np.diag(p0), (n_tr, n, n)).copy()

        noise = StreamingM2M4(n_tr, self.noise_window, prior_signal=A**2, prior_noise=self.nominal_noise)
        s4 = StreamingS4(n_tr, self.s4_window, prior=self.ar_sets[self.initial_set].s4, min_epochs=self.s4_min_epochs) if self.adaptive else None
        candidate = idx.copy()
        held = np.zeros(n_tr, dtype=int)

        out = np.empty((n_tr, k))
        rec = {name: np.empty((n_tr, k)) for name in self.record}
        shared = not self.adaptive
        F1, Q1, k1 = F_tab[self.initial_set], Q_tab[self.initial_set], kap_tab[self.initial_set]
        F1t = F1.T
        for i in range(k):
            # --- predict (eq. 11); the initial state is at epoch 0
            if i == 0:
                pass
            elif shared:
                x = x @ F1t + k1
                P = F1 @ P @ F1t + Q1
            else:
                Fi = F_tab[idx]
                x = np.einsum("nij,nj->ni", Fi, x) + kap_tab[idx]
                P = Fi @ P @ Fi.transpose(0, 2, 1) + Q_tab[idx]
            # --- update with z = [I, Q] (eqs. 13-14)
            yi = y[:, i]
            _, s2 = noise.update(yi)
            r = 0.5 * s2
            th = x[:, 0] + x[:, 3]
            rho = x[:, ir]
            c, s = np.cos(th), np.sin(th)
            a0, a1 = -A * rho * s, A * rho * c  # d h / d theta (rows I, Q)
            b0, b1 = A * c, A * s  # d h / d rho
            u = P[:, :, 0] + P[:, :, 3]
            v = P[:, :, ir]
            ph0 = a0[:, None] * u + b0[:, None] * v  # P H^T, column for I
            ph1 = a1[:, None] * u + b1[:, None] * v  # column for Q
            hu0 = ph0[:, 0] + ph0[:, 3]
            hu1 = ph1[:, 0] + ph1[:, 3]
            s00 = a0 * hu0 + b0 * ph0[:, ir] + r
            s01 = a0 * hu1 + b0 * ph1[:, ir]
            s11 = a1 * hu1 + b1 * ph1[:, ir] + r
            det = s00 * s11 - s01 * s01
            i00, i01, i11 = s11 / det, -s01 / det, s00 / det
            k0 = ph0 * i00[:, None] + ph1 * i01[:, None]
            k1_ = ph0 * i01[:, None] + ph1 * i11[:, None]
            e0 = yi.real - A * rho * c
            e1 = yi.imag - A * rho * s
            x = x + k0 * e0[:, None] + k1_ * e1[:, None]
            P = P - k0[:, :, None] * ph0[:, None, :] - k1_[:, :, None] * ph1[:, None, :]
            if self.fold_mirror:
                neg = x[:, ir] < 0.0
                if neg.any():
                    sign = np.where(np.arange(n) >= ir, -1.0, 1.0)
                    x[neg, 3:ir] += np.pi
                    x[neg] = x[neg] * sign
                    P[neg] = P[neg] * sign[None, :, None] * sign[None, None, :]
            if i % 64 == 63:
                P = 0.5 * (P + P.transpose(0, 2, 1))
            # --- adapt the SSM to the estimated S4 (Sec. V-B)
            if s4 is not None:
                s4_hat = s4.update(yi, s2)
                nearest = np.argmin(np.abs(s4_hat[:, None] - s4_points[None, :]), axis=1)
                # switch only when the nearest set has been the same for adapt_hold epochs
                held = np.where(nearest == candidate, held + 1, 0)
                candidate = nearest
                switch = held >= self.adapt_hold
                idx = np.where(switch, candidate, idx)
                if "s4_hat" in rec:
                    rec["s4_hat"][:, i] = s4_hat
            out[:, i] = x[:, 0]
            if "theta_s" in rec:
                rec["theta_s"][:, i] = x[:, 3]
            if "rho_s" in rec:
                rec["rho_s"][:, i] = x[:, ir]
            if "ar_set" in rec:
                rec["ar_set"][:, i] = idx
        return TrackOutput(theta_d=out, extras=rec)
