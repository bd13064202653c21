"""The Costas PLL as a receiver runs it: lock detector, frequency hold and an FLL-assisted re-pull.

The baseline of Zhao et al. (``zhao_receiver.pll``, :mod:`.pll`) is a bare
third-order Costas loop; once it has lost lock, its frequency integrators
integrate noise and the frequency runs to kHz.  A receiver does not let it:
it watches a lock detector, holds the NCO frequency when lock is lost and
re-pulls with a frequency loop.  This module is that loop, used by the
receiver when ``zhao_receiver.pll_lock`` is set (result name ``pll_fll``).

Per 1-ms epoch i with prompt ``y_i`` and NCO phase ``phi_i``:

* **In lock** the loop is the PLL of :mod:`.pll`, bit for bit: the Costas
  discriminator ``e_i = atan(Q_i / I_i)`` of ``y_i exp(-j phi_i)`` and
  :func:`.blocks.pll_step` (third order, ``Bn`` of the PLL's spec).
* **Lock detector** (the package's one,
  :func:`scintrack.experiments.lock_detector.lock_update`, with the
  receiver's ``zhao_receiver.lock`` threshold and window): at the end of
  every 20-ms data bit b (bit synchronisation is known) it takes
  ``D_b = atan(Q_b / I_b)`` of the bit's coherent sum
  ``P_b = sum_i y_i exp(-j phi_i)``, the receiver's own reading of the
  wrapped phase error modulo pi (data-insensitive); in lock while the
  running mean of ``|D_b|`` over ``window_s`` is at or below
  ``threshold_rad``.  The results' in-lock shares keep using the true error,
  the same for every variant.
* **Frequency hold**: when the detector falls out of lock at the end of bit
  b, the NCO frequency is set to the loop's frequency at the end of bit
  ``b - N`` (``N`` bits in the window): the last estimate no epoch of the
  failing window has touched; the frequency rate is set to 0.
* **FLL-assisted re-pull**, until the detector reads in lock again: the NCO
  phase advances by ``T (v + b3 w0 e_i)`` (the PLL's proportional path only,
  a first-order phase loop of noise bandwidth ``b3 w0 / 4``), and the
  frequency ``v`` follows a first-order FLL.  Its discriminator is the
  cross-product/atan2 of consecutive coherent sub-sums ``S_{m-1}, S_m`` of
  ``M = fll.integration_ms`` prompts inside one bit (no data transition
  between them):
  ``cross = I_{m-1} Q_m - I_m Q_{m-1}``, ``dot = I_{m-1} I_m + Q_{m-1} Q_m``,
  summed over the pairs of the bit, ``df_b = atan2(cross, dot) / (2 pi M T)``
  Hz (exact for a noise-free tone of offset ``df`` within the pull-in range
  ``+-1 / (2 M T)``).  Once per bit: ``v <- v + 2 pi K_F df_b`` with
  ``K_F = 4 B_F T_b / (1 + 2 B_F T_b)``, the gain of a first-order loop of
  noise bandwidth ``B_F`` updated every ``T_b = 20 ms``
  (``B_F = K / (2 T_b (2 - K))``).  The prompts are derotated by the NCO,
  whose frequency in the bit was ``v`` plus the proportional path's mean
  ``p_b / (2 pi T_b)`` (``p_b = sum_i T b3 w0 e_i``, the phase that path
  added in the bit), so the error of ``v`` is ``df_b + p_b / (2 pi T_b)``
  and that drives the update.  Without the second term the phase loop
  would absorb a frequency error as a static phase bias
  (``2 pi df / (b3 w0)``, 0.6 rad for 3 Hz), which the FLL cannot see and
  which keeps the detector out of lock.  ``B_F = 0`` is frequency hold
  alone.
* **Back in lock**: the third-order PLL resumes from the re-pulled phase and
  frequency, rate 0.

``extras["frequency_hz"]`` is ``v / 2 pi`` at every epoch (the frequency the
NCO runs at, without the proportional phase term), ``extras["locked"]`` the
detector's state at every epoch (the state decided at the end of the last
complete bit; in lock before the first).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from ..experiments.lock_detector import lock_update, window_epochs
from . import blocks, trig
from .base import TrackInit, TrackOutput
from .pll import PLL

BIT_MS = 20
_lock_update = njit(cache=True)(lock_update)


class PllLockParams(NamedTuple):
    """Everything :func:`pll_lock_kernel` needs besides the prompts."""

    phase0: np.ndarray  # (trials,) rad
    v0: np.ndarray  # (trials,) rad/s
    w0: np.ndarray  # (trials,) rad/s^2
    ts: float
    bandwidth_hz: float
    costas: bool
    bit_start: int  # first epoch of the first whole data bit
    threshold_rad: float
    window_bits: int
    fll_gain: float  # K_F
    fll_ms: int  # M, prompts per FLL sub-sum (divides 20)


def fll_gain(bandwidth_hz: float, update_s: float) -> float:
    """``K = 4 B T / (1 + 2 B T)``: the gain of a first-order loop of noise bandwidth ``B`` updated every ``T``."""
    bt = bandwidth_hz * update_s
    return 4.0 * bt / (1.0 + 2.0 * bt)


@njit(cache=True)
def fll_discriminator(cross, dot, interval_s):
    """Frequency error [Hz] from the summed cross and dot products of consecutive sub-sums ``interval_s`` apart."""
    return math.atan2(cross, dot) / (2.0 * math.pi * interval_s)


@njit(cache=True)
def pll_lock_kernel(y, prm):
    """The loop of the module docstring, trial by trial; returns (NCO phase, frequency [Hz], in lock) per epoch."""
    n, k = y.shape
    k3, k2, k1 = blocks.pll_constants(prm.bandwidth_hz, prm.ts)
    out = np.empty((n, k))
    freq = np.empty((n, k))
    locked_out = np.empty((n, k), dtype=np.bool_)
    nb = prm.window_bits
    buf = np.empty(nb)
    v_bits = np.empty(nb + 1)  # loop frequency at the end of the last nb + 1 bits (ring)
    m = prm.fll_ms
    for t in range(n):
        phase, v, w = prm.phase0[t], prm.v0[t], prm.w0[t]
        count, total, locked = 0, 0.0, True
        bits_done = 0
        v_start = v  # frequency before the first bit
        bi = 0.0
        bq = 0.0
        si = 0.0
        sq = 0.0
        pi_ = 0.0
        pq = 0.0
        cross = 0.0
        dot = 0.0
        prop = 0.0  # phase the proportional path added in the current bit (re-pull)
        for i in range(k):
            yr, yi = y[t, i].real, y[t, i].imag
            out[t, i] = phase
            freq[t, i] = v / (2.0 * np.pi)
            locked_out[t, i] = locked
            s_, c_ = trig.sincos(phase)
            zi = yr * c_ + yi * s_
            zq = yi * c_ - yr * s_
            if prm.costas:
                e = trig.atan(zq, zi)
            else:
                e = trig.atan2(zq, zi)
            if locked:
                phase, v, w = blocks.pll_step(phase, v, w, e, k3, k2, k1, prm.ts)
            else:
                phase = phase + (v + k1 * e) * prm.ts
                prop += k1 * e * prm.ts
            if i < prm.bit_start:
                continue
            j = (i - prm.bit_start) % BIT_MS  # epoch in its bit
            bi += zi
            bq += zq
            si += zi
            sq += zq
            if (j + 1) % m == 0:  # a sub-sum of M prompts is complete
                if j + 1 > m:  # it has a predecessor in the same bit
                    cross += pi_ * sq - si * pq
                    dot += pi_ * si + pq * sq
                pi_, pq = si, sq
                si = 0.0
                sq = 0.0
            if j == BIT_MS - 1:  # end of a data bit: detector, hold, FLL
                d = abs(trig.atan(bq, bi))
                count, total, now = _lock_update(buf, count, total, d, prm.threshold_rad)
                if not locked and prm.fll_gain > 0.0:
                    df = fll_discriminator(cross, dot, m * prm.ts) + prop / (2.0 * np.pi * BIT_MS * prm.ts)
                    v = v + 2.0 * np.pi * prm.fll_gain * df
                if locked and not now:  # lost: hold the frequency of the end of bit b - N
                    v = v_start if bits_done < nb else v_bits[(bits_done - nb) % (nb + 1)]
                    w = 0.0
                elif now and not locked:  # back in lock: the PLL resumes
                    w = 0.0
                locked = now
                v_bits[bits_done % (nb + 1)] = v
                bits_done += 1
                bi = 0.0
                bq = 0.0
                cross = 0.0
                dot = 0.0
                prop = 0.0
    return out, freq, locked_out


class PllLockSettings(NamedTuple):
    threshold_rad: float
    window_s: float
    fll_bandwidth_hz: float
    fll_integration_ms: int


def settings(pll_lock: Mapping[str, Any], lock: Mapping[str, Any]) -> PllLockSettings:
    """``zhao_receiver.pll_lock`` with the receiver's detector ``zhao_receiver.lock``; one error line for a bad value."""
    m = int(pll_lock["fll_integration_ms"])
    if m < 1 or BIT_MS % m or m == BIT_MS:
        raise ValueError(f"zhao_receiver.pll_lock.fll_integration_ms = {m}: must divide 20 and be below it (1, 2, 4, 5 or 10), "
                         "so that two consecutive sub-sums lie inside one data bit")
    return PllLockSettings(float(lock["threshold_rad"]), float(lock["window_s"]), float(pll_lock["fll_bandwidth_hz"]), m)


def run(pll: PLL, y: np.ndarray, init: TrackInit, bit_start: int, s: PllLockSettings) -> TrackOutput:
    """The PLL ``pll`` (its bandwidth, discriminator and epoch) with the detector, hold and FLL of ``s``."""
    base = pll.params(init)
    prm = PllLockParams(
        phase0=base.phase0, v0=base.v0, w0=base.w0, ts=base.ts, bandwidth_hz=base.bandwidth_hz, costas=base.costas,
        bit_start=int(bit_start), threshold_rad=s.threshold_rad, window_bits=window_epochs(BIT_MS * base.ts, s.window_s),
        fll_gain=fll_gain(s.fll_bandwidth_hz, BIT_MS * base.ts), fll_ms=s.fll_integration_ms,
    )
    phase, freq, locked = pll_lock_kernel(np.ascontiguousarray(y, dtype=complex), prm)
    return TrackOutput(theta_d=phase, extras={"frequency_hz": freq, "locked": locked})
