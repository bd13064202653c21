"""What every tracker shares: the interface, the dynamics model and the
discriminator.

Interface: ``tracker.run(y, init) -> TrackOutput`` where ``y`` holds prompt
samples shaped (trials, epochs) and ``init`` the acquisition values (initial
phase and Doppler per trial).  The time loop is the only Python loop; every
operation inside it is vectorised over trials.

Dynamics model (eq. 8 with m = 3): state ``[theta_d (rad), f_d (Hz), f_r (Hz/s)]``,
``F_d = [[1, 2 pi T, pi T^2], [0, 1, T], [0, 0, 1]]``; process noise from a
white Doppler-jerk of PSD ``q`` (Hz^2/s^3):
``Q_d = q [[(2pi)^2 T^5/20, 2pi T^4/8, 2pi T^3/6], [2pi T^4/8, T^3/3, T^2/2], [2pi T^3/6, T^2/2, T]]``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.special import erf


@dataclass
class TrackInit:
    """Acquisition output handed to every tracker (one value per trial)."""

    phase: np.ndarray
    doppler_hz: np.ndarray
    rate_hz_s: np.ndarray


@dataclass
class TrackOutput:
    """Estimates of the dynamics phase and optional extras, (trials, epochs)."""

    theta_d: np.ndarray
    extras: dict[str, np.ndarray] = field(default_factory=dict)


def dynamics_F(ts: float) -> np.ndarray:
    return np.array([[1.0, 2 * np.pi * ts, np.pi * ts**2], [0.0, 1.0, ts], [0.0, 0.0, 1.0]])


def dynamics_Q(q_jerk: float, ts: float) -> np.ndarray:
    t = ts
    c = 2 * np.pi
    return q_jerk * np.array(
        [
            [c * c * t**5 / 20, c * t**4 / 8, c * t**3 / 6],
            [c * t**4 / 8, t**3 / 3, t**2 / 2],
            [c * t**3 / 6, t**2 / 2, t],
        ]
    )


def atan2_discriminator(y: np.ndarray, phase: np.ndarray) -> np.ndarray:
    """Four-quadrant phase error of ``y`` against the replica phase, in (-pi, pi]."""
    r = y * np.exp(-1j * phase)
    return np.arctan2(r.imag, r.real)


def atan_variance(cn0_hz: np.ndarray | float, ts: float) -> np.ndarray:
    """Discriminator noise variance, eq. (12) of Vila-Valls 2018, evaluated at x = 2 C/N0 Ts.

    ``sigma^2 = (exp(-0.8 sqrt(x)) + 1) erf(0.4 x) / x``.  The paper writes
    the argument as C/N0 Ts; with that argument the formula tends to
    ``1/(C/N0 Ts)`` at high C/N0, twice the known high-SNR variance
    ``1/(2 C/N0 Ts)``.  With ``x = 2 C/N0 Ts`` it tends to the right limit and
    follows the Monte Carlo variance of the discriminator within about 5% from
    10 to 35 dB-Hz (reference notes §3.2; ``tests/test_trackers.py`` checks it).
    """
    x = np.maximum(2.0 * np.asarray(cn0_hz, dtype=float) * ts, 1e-6)
    return (np.exp(-0.8 * np.sqrt(x)) + 1.0) * erf(0.4 * x) / x


def companion(coefs: np.ndarray, size: int) -> np.ndarray:
    """AR companion block ``[[a1 .. a_size], [1 0 ..], ...]``, coefficients zero-padded."""
    out = np.zeros((size, size))
    out[0, : len(coefs)] = coefs
    out[np.arange(1, size), np.arange(size - 1)] = 1.0
    return out
