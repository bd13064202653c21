"""Wideband noise jamming of GPS L1 C/A: spectral separation coefficient and effective C/N0.

A band-limited white-noise jammer of power J, flat over ``bandwidth_hz``
centred ``offset_hz`` from L1, raises the noise floor the correlator sees by
``kappa * J``, where the spectral separation coefficient

``kappa = integral G_J(f) G_s(f) df``

is the overlap of the jammer's unit-power spectrum ``G_J`` with the C/A
code's unit-power spectrum ``G_s`` (Betz; Kaplan & Hegarty 2006, ch. 9).  So

``1/(C/N0)_eff = 1/(C/N0) + kappa J/C``,  J/C = J/S (the jammer-to-signal ratio).

``G_s`` is the continuous approximation of the C/A spectrum,
``T_c sinc^2(pi f T_c)`` with ``T_c = 1/1.023 MHz`` (the 1-kHz line
structure averages out over a jammer several MHz wide), optionally
band-limited to the receiver's front end and renormalised to unit power
there, since the receiver only keeps that part of the signal.  For the
paper's 8-MHz jammer centred on L1 and an unlimited front end,
``kappa = 0.9747 / 8 MHz = 1.218e-7 /Hz`` (97.5 % of C/A power lies within
+-4 MHz), and 46 -> 15 dB-Hz needs J/S = 54.1 dB.  The "Q = 2" rule of thumb
(``kappa = 1/(Q R_c)``) would give 48.1 dB; we compute ``kappa`` instead.
"""

from __future__ import annotations

import numpy as np
from scipy import integrate

CHIP_RATE_HZ = 1.023e6


def ca_psd(f_hz: np.ndarray | float) -> np.ndarray:
    """Unit-power continuous C/A spectrum ``T_c sinc^2(pi f T_c)`` (1/Hz)."""
    tc = 1.0 / CHIP_RATE_HZ
    return tc * np.sinc(np.asarray(f_hz, dtype=float) * tc) ** 2  # numpy's sinc(x) = sin(pi x)/(pi x)


def _ca_power(lo: float, hi: float) -> float:
    """Fraction of C/A power between ``lo`` and ``hi`` Hz."""
    points = [k * CHIP_RATE_HZ for k in range(int(np.floor(lo / CHIP_RATE_HZ)), int(np.ceil(hi / CHIP_RATE_HZ)) + 1) if lo < k * CHIP_RATE_HZ < hi]
    value, _ = integrate.quad(ca_psd, lo, hi, points=points or None, limit=max(400, 2 * len(points) + 50), epsabs=1e-13, epsrel=1e-11)
    return float(value)


def spectral_separation(bandwidth_hz: float, offset_hz: float = 0.0, front_end_hz: float | None = None) -> float:
    """``kappa`` (1/Hz) of a flat jammer of ``bandwidth_hz`` centred ``offset_hz`` from L1.

    ``front_end_hz`` is the receiver's two-sided bandwidth (None = unlimited):
    both spectra are cut to it and renormalised to unit power inside it.
    """
    if bandwidth_hz <= 0:
        raise ValueError(f"jammer bandwidth must be > 0 Hz (got {bandwidth_hz})")
    lo, hi = offset_hz - bandwidth_hz / 2.0, offset_hz + bandwidth_hz / 2.0
    signal_norm = 1.0
    jam_power = 1.0
    if front_end_hz is not None:
        half = front_end_hz / 2.0
        signal_norm = _ca_power(-half, half)
        jam_power = max(0.0, min(hi, half) - max(lo, -half)) / bandwidth_hz
        lo, hi = max(lo, -half), min(hi, half)
        if hi <= lo:
            return 0.0
    overlap = _ca_power(lo, hi) / bandwidth_hz  # G_J = 1/B on [lo, hi]
    return overlap / signal_norm / jam_power if jam_power > 0 else 0.0


def effective_cn0_dbhz(cn0_dbhz: np.ndarray | float, js_db: np.ndarray | float, kappa: float) -> np.ndarray:
    """Effective C/N0 (dB-Hz) with a jammer at ``js_db`` dB above the signal; ``-inf`` J/S = no jammer."""
    cn0 = 10.0 ** (np.asarray(cn0_dbhz, dtype=float) / 10.0)
    js = 10.0 ** (np.asarray(js_db, dtype=float) / 10.0)
    return 10.0 * np.log10(1.0 / (1.0 / cn0 + kappa * js))


def js_for_cn0_db(cn0_dbhz: float, target_dbhz: float, kappa: float) -> float:
    """The J/S (dB) that lowers ``cn0_dbhz`` to ``target_dbhz``."""
    if target_dbhz >= cn0_dbhz:
        raise ValueError(f"target C/N0 {target_dbhz} dB-Hz must be below the clean {cn0_dbhz} dB-Hz")
    excess = 10.0 ** (-target_dbhz / 10.0) - 10.0 ** (-cn0_dbhz / 10.0)
    return float(10.0 * np.log10(excess / kappa))
