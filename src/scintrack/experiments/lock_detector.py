"""The GPS receiver's lock detector, in plain numpy (a figure job uses it without the compute stack).

A channel is **in lock** while the running mean of its |wrapped phase error|
over the last ``window_s`` seconds (over what exists at the start) stays at
or below ``threshold`` rad; a **loss-of-lock event** is an in-lock -> out-of-lock
transition.  The thresholds are the config's ``zhao_receiver.lock``.

Two forms of the one detector: :func:`lock_state` reads a whole error series
at once (results and figures, from the true error); :func:`lock_update` is
the same running mean fed one |error| at a time, for a loop that must decide
on line (the receiver's PLL with frequency hold and FLL re-pull,
:mod:`scintrack.trackers.pll_lock`, compiles it with numba and feeds it its
own discriminator).  Both use :func:`window_epochs`; a test checks that they
give the same states.
"""

from __future__ import annotations

import numpy as np


def lock_state(error: np.ndarray, ts: float, threshold: float, window_s: float) -> np.ndarray:
    """In lock (True) while the running mean of |wrapped error| over ``window_s`` stays at or below ``threshold``."""
    n = window_epochs(ts, window_s)
    a = np.abs(error)
    c = np.cumsum(np.concatenate([np.zeros((*a.shape[:-1], 1)), a], axis=-1), axis=-1)
    idx = np.arange(a.shape[-1])
    lo = np.maximum(idx - n + 1, 0)
    return (c[..., idx + 1] - c[..., lo]) / (idx + 1 - lo) <= threshold


def loss_of_lock_events(locked: np.ndarray) -> np.ndarray:
    """Number of in-lock -> out-of-lock transitions per row."""
    return np.sum(locked[..., :-1] & ~locked[..., 1:], axis=-1)


def window_epochs(ts: float, window_s: float) -> int:
    """Epochs of ``ts`` seconds in the detector's window (at least one)."""
    return max(1, int(round(window_s / ts)))


def lock_update(buf, count, total, x, threshold):
    """One step of :func:`lock_state` on line: add ``x = |error|`` of the next epoch.

    ``buf`` (length :func:`window_epochs`) holds the last values in a ring, ``count`` the epochs seen so far and
    ``total`` their sum over the window; returns ``(count, total, in_lock)`` after the epoch: in lock while the
    mean over the last ``len(buf)`` epochs (all of them at the start) is at or below ``threshold``.  Plain Python
    on scalars and one array, so numba compiles it unchanged.
    """
    n = buf.shape[0]
    slot = count % n
    if count >= n:
        total -= buf[slot]
    buf[slot] = x
    total += x
    count += 1
    return count, total, total / min(count, n) <= threshold
