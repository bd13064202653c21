"""Discriminator-based Kalman filters: KF, AKF and AKF-AR (Vila-Valls 2018, Sec. V-A, VI).

One filter, three configurations (they differ only in R and in the state):

* **KF**: state ``x1 = [theta_d, f_d, f_r]`` (eq. 8, m = 3), measurement the
  ATAN2 discriminator output on the predicted phase, ``H = [1, 0, 0]``, fixed
  ``R`` = eq. (12) at the nominal C/N0 ("heuristically set from the expected
  propagation conditions").
* **AKF**: the same with ``R_k`` = eq. (12) at the on-line M2M4 C/N0 estimate.
* **AKF-AR** (ref. [14]): AKF with the state augmented by the AR(p)
  scintillation phase ``[theta_s,k .. theta_s,k-p+1]`` (eq. 9), ``H = [1, 0, 0, 1, 0..]``;
  AR parameters fixed (no adaptation to time-varying conditions).

The discriminator measures ``H x - H x_pred`` wrapped to (-pi, pi], so the
innovation is the discriminator output itself.  With a fixed R the covariance
recursion is the same for every trial and is computed once per epoch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..estimators.cn0 import StreamingM2M4, cn0_from_powers
from .base import TrackInit, TrackOutput, atan2_discriminator, atan_variance, companion, dynamics_F, dynamics_Q


@dataclass
class DiscriminatorKF:
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

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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

    def _initial(self, init: TrackInit, n_tr: int, n: int) -> tuple[np.ndarray, np.ndarray]:
        x = np.zeros((n_tr, n))
        x[:, 0], x[:, 1], x[:, 2] = init.phase, init.doppler_hz, init.rate_hz_s
        p0 = np.zeros((n, n))
        p0[np.arange(3), np.arange(3)] = self.p0_diag
        if n > 3:
            p0[np.arange(3, n), np.arange(3, n)] = self.ar_p0
        return x, p0

    def run(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """Compiled loop (:func:`scintrack.trackers.kernels.kf_kernel`)."""
        from .kernels import kf_kernel, nonzeros

        F, Q, H = self.matrices()
        x, p0 = self._initial(init, y.shape[0], F.shape[0])
        noise0 = self.amplitude**2 / (self.nominal_cn0_hz * self.ts)
        out, r_out = kf_kernel(
            np.ascontiguousarray(y, dtype=complex), x, p0, F, Q, H, bool(self.adaptive_r),
            float(atan_variance(self.nominal_cn0_hz, self.ts)), int(self.cn0_window),
            float(self.amplitude**2), float(noise0), float(self.ts), 10, 1e-3, *nonzeros(F),
        )
        return TrackOutput(theta_d=out, extras={"R": r_out} if self.adaptive_r else {})

    def run_numpy(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """Vectorised numpy reference of the same filter."""
        n_tr, k = y.shape
        F, Q, H = self.matrices()
        n = F.shape[0]
        x, p0 = self._initial(init, n_tr, n)
        noise0 = self.amplitude**2 / (self.nominal_cn0_hz * self.ts)
        r_fixed = float(atan_variance(self.nominal_cn0_hz, self.ts))
        if self.adaptive_r:
            P = np.broadcast_to(p0, (n_tr, n, n)).copy()
            cn0 = StreamingM2M4(n_tr, self.cn0_window, prior_signal=self.amplitude**2, prior_noise=noise0)
        else:
            P = p0.copy()
        out = np.empty((n_tr, k))
        r_out = np.empty((n_tr, k)) if self.adaptive_r else None
        Ft = F.T
        for i in range(k):
            if i > 0:  # predict (the initial state is at epoch 0)
                x = x @ Ft
                P = F @ P @ Ft + Q
            # measurement: discriminator on the predicted total phase
            yi = y[:, i]
            nu = atan2_discriminator(yi, x @ H)
            if self.adaptive_r:
                sig, noi = cn0.update(yi)
                R = atan_variance(cn0_from_powers(sig, noi, self.ts), self.ts)
                PH = P @ H  # (n_tr, n)
                S = PH @ H + R
                K = PH / S[:, None]
                x = x + K * nu[:, None]
                P = P - K[:, :, None] * PH[:, None, :]
                r_out[:, i] = R
            else:
                PH = P @ H
                S = PH @ H + r_fixed
                K = PH / S
                x = x + nu[:, None] * K[None, :]
                P = P - np.outer(K, PH)
            out[:, i] = x[:, 0]
        extras = {"R": r_out} if r_out is not None else {}
        return TrackOutput(theta_d=out, extras=extras)
