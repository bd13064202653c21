"""Sliding-window running sums over the last N epochs, vectorised over trials.

The building block of the streaming estimators: ``push`` adds one epoch of
values (shape (trials, k)) and returns the window sums and the number of
epochs in the window.  Sums are exact (a ring buffer subtracts the value that
leaves the window) and re-computed from the buffer every ``N`` epochs so that
floating-point drift cannot accumulate.
"""

from __future__ import annotations

import numpy as np


class SlidingSums:
    def __init__(self, n_trials: int, n_values: int, window: int):
        if window < 1:
            raise ValueError("window must be >= 1 epoch")
        self.window = int(window)
        self.buffer = np.zeros((self.window, n_trials, n_values))
        self.sums = np.zeros((n_trials, n_values))
        self.count = 0
        self._pos = 0

    def push(self, values: np.ndarray) -> tuple[np.ndarray, int]:
        old = self.buffer[self._pos]
        self.sums += values - old
        self.buffer[self._pos] = values
        self._pos = (self._pos + 1) % self.window
        self.count = min(self.count + 1, self.window)
        if self._pos == 0:
            self.sums = self.buffer.sum(axis=0)
        return self.sums, self.count
