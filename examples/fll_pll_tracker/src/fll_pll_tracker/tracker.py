"""FLL-assisted third-order PLL: tracker type ``example_fll_pll``.

A third-order PLL whose loop filter is also driven by a second-order FLL
(Kaplan & Hegarty, Understanding GPS, 2nd ed., Sec. 5.5.2 and Fig. 5.22b).
Per epoch k, with the NCO phase ``phi_k`` that correlates the epoch and the
residual prompt ``z_k = y_k exp(-j phi_k)``:

* phase error ``e_p = atan2(Im z_k, Re z_k)`` [rad] (four-quadrant: a pilot signal);
* frequency error ``e_f = atan2(cross, dot) / T`` [rad/s], ``dot + j cross = z_k conj(z_{k-1})``
  (the cross-product discriminator; 0 at the first epoch);
* loop filter, bilinear integrators, ``w0p = Bn / 0.7845``, ``a3 = 1.1``, ``b3 = 2.4``,
  ``w0f = Bn_f / 0.53``, ``a2 = 1.414``:

  - ``w_k = w_{k-1} + T (w0p^3 e_p + w0f^2 e_f)``
  - ``v_k = v_{k-1} + T ((w_k + w_{k-1})/2 + a3 w0p^2 e_p + a2 w0f e_f)``
  - ``f_k = (v_k + v_{k-1})/2 + b3 w0p e_p`` [rad/s], and ``phi_{k+1} = phi_k + f_k T``.

The estimate at epoch k is ``phi_k`` (the prediction), the carrier phase the
loop tracks.  ``run`` is a plain numba loop, one trial after the other (so a
trial's result never depends on its batch); ``reference`` is the same loop in
numpy, vectorised over trials, which ``scintrack.testing.check_tracker``
compares it with.

Config: ``{type: example_fll_pll, bandwidth_hz: 10, fll_bandwidth_hz: 2}``;
``bandwidth_hz`` defaults to the shared ``tracking.pll_bandwidth_hz``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from scintrack.trackers.base import Tracker, TrackerContext, TrackInit, TrackOutput

PLL_BN_PER_W0, PLL_A3, PLL_B3 = 0.7845, 1.1, 2.4  # third-order PLL (Kaplan & Hegarty Table 5.6)
FLL_BN_PER_W0, FLL_A2 = 0.53, 1.414  # second-order FLL
FLL_BANDWIDTH_HZ = 2.0  # default FLL noise bandwidth


def gains(bandwidth_hz: float, fll_bandwidth_hz: float) -> tuple[float, float]:
    """(w0p, w0f): natural frequencies of the PLL and the FLL [rad/s]."""
    return bandwidth_hz / PLL_BN_PER_W0, fll_bandwidth_hz / FLL_BN_PER_W0


@njit(cache=True)
def fll_pll_kernel(y, phase0, v0, w0, ts, wp, wf):
    """The loop of the module docstring for every trial of ``y`` (trials, epochs); returns (phase, frequency [Hz], e_p)."""
    n, k = y.shape
    out = np.empty((n, k))
    freq = np.empty((n, k))
    disc = np.empty((n, k))
    for t in range(n):
        phase, v, w = phase0[t], v0[t], w0[t]
        zr_prev, zi_prev = 0.0, 0.0
        for i in range(k):
            c, s = math.cos(phase), math.sin(phase)
            yr, yi = y[t, i].real, y[t, i].imag
            zr, zi = yr * c + yi * s, yi * c - yr * s  # y exp(-j phase)
            ep = math.atan2(zi, zr)
            ef = 0.0 if i == 0 else math.atan2(zi * zr_prev - zr * zi_prev, zr * zr_prev + zi * zi_prev) / ts
            out[t, i] = phase
            freq[t, i] = v / (2.0 * math.pi)
            disc[t, i] = ep
            w_new = w + ts * (wp**3 * ep + wf**2 * ef)
            v_new = v + ts * (0.5 * (w_new + w) + PLL_A3 * wp**2 * ep + FLL_A2 * wf * ef)
            phase = phase + (0.5 * (v_new + v) + PLL_B3 * wp * ep) * ts
            v, w = v_new, w_new
            zr_prev, zi_prev = zr, zi
    return out, freq, disc


@dataclass
class FllAssistedPll(Tracker):
    ts: float
    bandwidth_hz: float
    fll_bandwidth_hz: float = FLL_BANDWIDTH_HZ

    SCHEMA = {
        "bandwidth_hz": {"type": "number", "exclusiveMinimum": 0, "maximum": 50, "description": "PLL noise bandwidth Bn [Hz] (default: tracking.pll_bandwidth_hz)"},
        "fll_bandwidth_hz": {"type": "number", "exclusiveMinimum": 0, "maximum": 20, "description": f"FLL noise bandwidth [Hz] (default {FLL_BANDWIDTH_HZ:g})"},
    }
    TRACKING_KEYS = ("pll_bandwidth_hz",)
    SPEC_OVERRIDES = {"bandwidth_hz": "pll_bandwidth_hz"}
    PROVIDES = frozenset({"frequency_hz", "discriminator"})

    @classmethod
    def from_spec(cls, spec: Mapping[str, Any], context: TrackerContext) -> FllAssistedPll:
        bandwidth = spec["bandwidth_hz"] if "bandwidth_hz" in spec else context.tracking["pll_bandwidth_hz"]
        return cls(ts=float(context.ts), bandwidth_hz=float(bandwidth), fll_bandwidth_hz=float(spec.get("fll_bandwidth_hz", FLL_BANDWIDTH_HZ)))

    @staticmethod
    def label(name: str, spec: Mapping[str, Any]) -> str:
        parts = [f"Bn = {float(spec[k]):g} Hz" if k == "bandwidth_hz" else f"FLL {float(spec[k]):g} Hz"
                 for k in ("bandwidth_hz", "fll_bandwidth_hz") if k in spec]
        return "FLL-assisted PLL" + (f" ({', '.join(parts)})" if parts else "")

    def _start(self, init: TrackInit):
        return (np.asarray(init.phase, dtype=float), 2 * np.pi * np.asarray(init.doppler_hz, dtype=float),
                2 * np.pi * np.asarray(init.rate_hz_s, dtype=float))

    def run(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        phase0, v0, w0 = self._start(init)
        wp, wf = gains(self.bandwidth_hz, self.fll_bandwidth_hz)
        phase, freq, disc = fll_pll_kernel(np.ascontiguousarray(y, dtype=complex), phase0, v0, w0, float(self.ts), wp, wf)
        return TrackOutput(theta_d=phase, extras={"frequency_hz": freq, "discriminator": disc})

    def reference(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """The same loop in numpy, all trials at once."""
        phase, v, w = (a.copy() for a in self._start(init))
        wp, wf = gains(self.bandwidth_hz, self.fll_bandwidth_hz)
        T = self.ts
        out, freq, disc = (np.empty(y.shape) for _ in range(3))
        z_prev = None
        for i in range(y.shape[1]):
            z = y[:, i] * np.exp(-1j * phase)
            ep = np.angle(z)
            ef = np.zeros_like(ep) if z_prev is None else np.angle(z * np.conj(z_prev)) / T
            out[:, i], freq[:, i], disc[:, i] = phase, v / (2 * np.pi), ep
            w_new = w + T * (wp**3 * ep + wf**2 * ef)
            v_new = v + T * (0.5 * (w_new + w) + PLL_A3 * wp**2 * ep + FLL_A2 * wf * ef)
            phase = phase + (0.5 * (v_new + v) + PLL_B3 * wp * ep) * T
            v, w, z_prev = v_new, w_new, z
        return TrackOutput(theta_d=out, extras={"frequency_hz": freq, "discriminator": disc})
