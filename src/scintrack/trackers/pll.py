"""Third-order PLL with an ATAN2 discriminator (the paper's "PLL").

Loop filter (Kaplan & Hegarty; reference notes §3.1), bilinear integrators,
discriminator ``e_k`` in rad, frequency command in rad/s:

* ``w_k = w_{k-1} + T w0^3 e_k``
* ``v_k = v_{k-1} + T ((w_k + w_{k-1})/2 + a3 w0^2 e_k)``
* ``f_k = (v_k + v_{k-1})/2 + b3 w0 e_k``

with ``w0 = Bn / 0.7845``, ``a3 = 1.1``, ``b3 = 2.4``.  The NCO advances the
replica phase by ``f_k T``.  The phase estimate at epoch k is the NCO phase
used to correlate that epoch (the prediction); the PLL tracks the total phase
``theta_d + theta_s``, as every loop without a scintillation model does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import TrackInit, TrackOutput, atan2_discriminator

A3, B3, W0_PER_BN = 1.1, 2.4, 1.0 / 0.7845


@dataclass
class PLL:
    ts: float
    bandwidth_hz: float

    def run(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """Compiled loop (:func:`scintrack.trackers.kernels.pll_kernel`)."""
        from .kernels import pll_kernel

        out = pll_kernel(
            np.ascontiguousarray(y, dtype=complex), np.asarray(init.phase, dtype=float),
            2 * np.pi * np.asarray(init.doppler_hz, dtype=float), 2 * np.pi * np.asarray(init.rate_hz_s, dtype=float),
            float(self.ts), float(self.bandwidth_hz),
        )
        return TrackOutput(theta_d=out)

    def run_numpy(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """Vectorised numpy reference of the same loop."""
        n, k = y.shape
        w0 = self.bandwidth_hz * W0_PER_BN
        t = self.ts
        phase = np.array(init.phase, dtype=float)
        w = 2 * np.pi * np.asarray(init.rate_hz_s, dtype=float)  # rad/s^2
        v = 2 * np.pi * np.asarray(init.doppler_hz, dtype=float)  # rad/s
        out = np.empty((n, k))
        for i in range(k):
            out[:, i] = phase
            e = atan2_discriminator(y[:, i], phase)
            w_new = w + t * w0**3 * e
            v_new = v + t * (0.5 * (w_new + w) + A3 * w0**2 * e)
            f = 0.5 * (v_new + v) + B3 * w0 * e
            w, v = w_new, v_new
            phase = phase + f * t
        return TrackOutput(theta_d=out)
