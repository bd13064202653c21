"""Receiver-satellite carrier dynamics (Vila-Valls 2018, eqs. 7-8, m = 3).

``theta_d(t) = theta_0 + 2 pi (f_d0 t + f_r t^2 / 2)`` with a random initial
phase ``theta_0 ~ U[-pi, pi]`` per trial (the paper's aeronautical case:
f_d0 = 50 Hz, f_r = 100 Hz/s, i.e. about 20 m/s^2 at L1).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..seeding import rng_for


def initial_phases(seed: int, name: str, trials: Sequence[int]) -> np.ndarray:
    return np.array([rng_for(seed, name, t).uniform(-np.pi, np.pi) for t in trials])


def third_order_phase(theta0: np.ndarray, n_epochs: int, ts: float, fd0_hz: float, fr_hz_s: float) -> np.ndarray:
    """Dynamics phase in rad, shape (trials, epochs), sampled at ``k Ts``."""
    t = np.arange(n_epochs) * ts
    return np.asarray(theta0)[:, None] + 2.0 * np.pi * (fd0_hz * t + 0.5 * fr_hz_s * t**2)[None, :]
