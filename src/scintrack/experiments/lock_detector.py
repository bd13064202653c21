"""The GPS receiver's lock detector, in plain numpy (a figure job uses it without the compute stack).

A channel is **in lock** while the running mean of its |wrapped phase error|
over the last ``window_s`` seconds (over what exists at the start) stays at
or below ``threshold`` rad; a **loss-of-lock event** is an in-lock -> out-of-lock
transition.  The thresholds are the config's ``zhao_receiver.lock``.
"""

from __future__ import annotations

import numpy as np


def lock_state(error: np.ndarray, ts: float, threshold: float, window_s: float) -> np.ndarray:
    """In lock (True) while the running mean of |wrapped error| over ``window_s`` stays at or below ``threshold``."""
    n = max(1, int(round(window_s / ts)))
    a = np.abs(error)
    c = np.cumsum(np.concatenate([np.zeros((*a.shape[:-1], 1)), a], axis=-1), axis=-1)
    idx = np.arange(a.shape[-1])
    lo = np.maximum(idx - n + 1, 0)
    return (c[..., idx + 1] - c[..., lo]) / (idx + 1 - lo) <= threshold


def loss_of_lock_events(locked: np.ndarray) -> np.ndarray:
    """Number of in-lock -> out-of-lock transitions per row."""
    return np.sum(locked[..., :-1] & ~locked[..., 1:], axis=-1)
