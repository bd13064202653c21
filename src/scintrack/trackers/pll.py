"""Third-order PLL with an ATAN2 (pilot) or Costas ATAN (data) discriminator; type ``pll``.

Loop filter (Kaplan & Hegarty; reference notes §3.1), bilinear integrators,
discriminator ``e_k`` in rad, frequency command in rad/s:

* ``w_k = w_{k-1} + T w0^3 e_k``
* ``v_k = v_{k-1} + T ((w_k + w_{k-1})/2 + a3 w0^2 e_k)``
* ``f_k = (v_k + v_{k-1})/2 + b3 w0 e_k``

with ``w0 = Bn / 0.7845``, ``a3 = 1.1``, ``b3 = 2.4``
(:func:`.blocks.pll_constants`, :func:`.blocks.pll_step`).  The NCO advances the
replica phase by ``f_k T``.  The phase estimate at epoch k is the NCO phase
used to correlate that epoch (the prediction); the PLL tracks the total phase
``theta_d + theta_s``, as every loop without a scintillation model does.

Config: ``{type: pll, bandwidth_hz: 10}`` (default ``tracking.pll_bandwidth_hz``);
``discriminator: atan`` selects the two-quadrant Costas discriminator
``atan(Q/I)`` for signals with data bits (Zhao et al.'s baseline; the error
is then ambiguous by pi); the default ``atan2`` is the Vila-Valls pilot loop.
``extras["frequency_hz"]`` is the loop's frequency command ``v / 2 pi`` and
``extras["discriminator"]`` the discriminator output ``e_k`` (recomputed from
the prompts and the NCO phases, the same numbers the loop used).

Lanes: :func:`pll_kernel` runs ``blocks.LANES`` (32) trials side by side, one
SIMD vector per quantity: the discriminator (:mod:`.trig`'s sine, cosine and
atan2 / atan, :func:`.blocks.prompt_discriminator_lanes`) and
:func:`.blocks.pll_step` on ``Lanes``.  No operation is fused or reassociated
(no fast-math) and no lane reads another, so a trial's result does not depend
on its batch; a last block with fewer trials computes copies of its last
trial (discarded).  Tests (``tests/test_lane_kernels.py``): the kernel against
:meth:`PLL.reference`, the same bits in batches of 1, 31, 32, 33 and 40
trials, NaN and inf prompts.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from ..simd.lanes import lane_load, lane_store
from . import blocks
from .base import Tracker, TrackerContext, TrackInit, TrackOutput, atan2_discriminator
from .registry import register


class PllParams(NamedTuple):
    """Everything :func:`pll_kernel` needs besides the prompts."""

    phase0: np.ndarray  # (trials,) rad
    v0: np.ndarray  # (trials,) rad/s
    w0: np.ndarray  # (trials,) rad/s^2
    ts: float
    bandwidth_hz: float
    costas: bool


@njit(cache=True)
def pll_kernel(y, prm):
    """The PLL, ``blocks.LANES`` trials at a time (trial on the last axis: SIMD over trials).

    Per epoch: the discriminator on Lanes (:mod:`.trig`), :func:`.blocks.pll_step` on Lanes; no lane
    reads another, so every trial's result is the one it has alone, bit for bit.  A short last block
    computes copies of its last trial (not written).
    """
    L = blocks.LANES
    n, k = y.shape
    k3, k2, k1 = blocks.pll_constants(prm.bandwidth_hz, prm.ts)
    out = np.empty((n, k))
    freq = np.empty((n, k))
    disc = np.empty((n, k))
    phase = blocks.lanes_empty((L,))
    v = blocks.lanes_empty((L,))
    w = blocks.lanes_empty((L,))
    e = blocks.lanes_empty((L,))
    yr = blocks.lanes_empty((L,))
    yi = blocks.lanes_empty((L,))
    trial = np.empty(L, dtype=np.int64)
    for c0 in range(0, n, L):
        m = blocks.lane_trials(c0, n, trial)  # trials of this block written out
        for ln in range(L):
            t = trial[ln]
            phase[ln], v[ln], w[ln] = prm.phase0[t], prm.v0[t], prm.w0[t]
        for i in range(k):
            blocks.prompt_discriminator_lanes(y, trial, i, phase, prm.costas, yr, yi, e)
            for ln in range(m):
                t = trial[ln]
                out[t, i] = phase[ln]
                freq[t, i] = v[ln] / (2.0 * np.pi)
                disc[t, i] = e[ln]
            ph_n, v_n, w_n = blocks.pll_step(lane_load(phase, 0), lane_load(v, 0), lane_load(w, 0), lane_load(e, 0), k3, k2, k1, prm.ts)
            lane_store(phase, 0, ph_n)
            lane_store(v, 0, v_n)
            lane_store(w, 0, w_n)
    return out, freq, disc


@register("pll")
@dataclass
class PLL(Tracker):
    ts: float
    bandwidth_hz: float
    discriminator: str = "atan2"

    TRACKING_KEYS = ("pll_bandwidth_hz",)
    PROVIDES = frozenset({"frequency_hz", "discriminator"})
    SPEC_OVERRIDES = {"bandwidth_hz": "pll_bandwidth_hz"}
    SCHEMA = {
        "bandwidth_hz": {"type": "number", "exclusiveMinimum": 0, "maximum": 50, "description": "loop noise bandwidth Bn [Hz] (default: tracking.pll_bandwidth_hz)"},
        "discriminator": {"enum": ["atan2", "atan"], "description": "atan2 (pilot, default) or atan (Costas, data-insensitive)"},
    }

    @classmethod
    def from_spec(cls, spec: Mapping[str, Any], context: TrackerContext) -> PLL:
        bandwidth = spec["bandwidth_hz"] if "bandwidth_hz" in spec else context.tracking["pll_bandwidth_hz"]
        return cls(ts=context.ts, bandwidth_hz=float(bandwidth), discriminator=str(spec.get("discriminator", "atan2")))

    @staticmethod
    def label(name: str, spec: Mapping[str, Any]) -> str:
        base = "Costas PLL" if spec.get("discriminator") == "atan" else "PLL"
        return base if "bandwidth_hz" not in spec else f"{base} (Bn = {float(spec['bandwidth_hz']):g} Hz)"

    def params(self, init: TrackInit) -> PllParams:
        return PllParams(
            phase0=np.asarray(init.phase, dtype=float), v0=2 * np.pi * np.asarray(init.doppler_hz, dtype=float),
            w0=2 * np.pi * np.asarray(init.rate_hz_s, dtype=float), ts=float(self.ts), bandwidth_hz=float(self.bandwidth_hz),
            costas=self.discriminator == "atan",
        )

    def run(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """Compiled loop (:func:`pll_kernel`)."""
        y = np.ascontiguousarray(y, dtype=complex)
        phase, freq, disc = pll_kernel(y, self.params(init))  # disc: the e_k the loop used (= discriminator_output)
        return TrackOutput(theta_d=phase, extras={"frequency_hz": freq, "discriminator": disc})

    def discriminator_output(self, y: np.ndarray, phase: np.ndarray) -> np.ndarray:
        """``e_k`` of every epoch: the discriminator of the prompt against the NCO phase that correlated it."""
        if self.discriminator == "atan":
            return blocks.atan_discriminator_ufunc(y.real, y.imag, phase)
        return atan2_discriminator(y, phase)

    def reference(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """The same loop in numpy, vectorised over trials (the blocks applied to arrays)."""
        prm = self.params(init)
        k3, k2, k1 = blocks.pll_constants(prm.bandwidth_hz, prm.ts)
        phase, v, w = prm.phase0.copy(), prm.v0.copy(), prm.w0.copy()
        out = np.empty(y.shape)
        freq = np.empty(y.shape)
        for i in range(y.shape[1]):
            out[:, i] = phase
            freq[:, i] = v / (2 * np.pi)
            if prm.costas:
                e = blocks.atan_discriminator_ufunc(y[:, i].real, y[:, i].imag, phase)
            else:
                e = atan2_discriminator(y[:, i], phase)
            phase, v, w = blocks.pll_step(phase, v, w, e, k3, k2, k1, prm.ts)
        return TrackOutput(theta_d=out, extras={"frequency_hz": freq, "discriminator": self.discriminator_output(y, out)})
