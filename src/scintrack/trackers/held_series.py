"""A tracker output that holds one value per trial over runs of epochs, stored once per run.

The SAKF's monitors (Phi3, T, p and the gain weight; :mod:`.susi_kf`) change
only when the scintillation blocks refresh, every ``update_s`` (100 epochs at
1 ms); a (trials, epochs) array of each, written epoch by epoch, would be four
arrays of 60 MB for 25 trials x 300 000 epochs, the largest part of a Susi
shard's fresh memory after the prompts.
:class:`HeldSeries` keeps the values of each run once, ``values`` shaped
(trials, runs), with the first epoch of every run in ``starts``.

It reads as the (trials, epochs) array it stands for: ``numpy.asarray`` (and
anything that converts it) gives exactly that array (``numpy.repeat`` of the
stored values, so the same bits as writing them epoch by epoch), and
``shape``/``dtype``/``ndim`` are the array's.  Indexing with a slice of
trials gives a :class:`HeldSeries` of those trials (no expansion); any other
index is applied to the expanded array.  Reductions over trials that are
computed column by column (a sum, a NaN-mean, a median) give the same bits
on :attr:`values` as on every epoch of a run, since each epoch's column is
its run's column; :mod:`scintrack.experiments.runner` uses that and expands
only the 1-D result (:meth:`expand_columns`).
"""

from __future__ import annotations

import numpy as np


class HeldSeries:
    """(trials, epochs) values held over runs of epochs: ``values`` (trials, runs), ``starts`` (runs,), ``n_epochs``."""

    __slots__ = ("values", "starts", "n_epochs")

    def __init__(self, values: np.ndarray, starts: np.ndarray, n_epochs: int) -> None:
        values = np.asarray(values)
        starts = np.asarray(starts, dtype=np.int64)
        n_epochs = int(n_epochs)
        if values.ndim != 2 or starts.ndim != 1 or values.shape[1] != starts.size:
            raise ValueError(f"values {values.shape} must be (trials, runs) with one start per run (starts {starts.shape})")
        if starts.size and (starts[0] != 0 or np.any(np.diff(starts) <= 0) or starts[-1] >= n_epochs):
            raise ValueError(f"starts must rise strictly from 0 and stay below n_epochs = {n_epochs}")
        if not starts.size and n_epochs:
            raise ValueError(f"{n_epochs} epochs need at least one run")
        self.values, self.starts, self.n_epochs = values, starts, n_epochs

    @property
    def counts(self) -> np.ndarray:
        """Epochs in each run."""
        return np.diff(np.append(self.starts, self.n_epochs))

    @property
    def shape(self) -> tuple[int, int]:
        return (self.values.shape[0], self.n_epochs)

    @property
    def ndim(self) -> int:
        return 2

    @property
    def dtype(self) -> np.dtype:
        return self.values.dtype

    def __len__(self) -> int:
        return self.values.shape[0]

    def expand_columns(self, columns: np.ndarray) -> np.ndarray:
        """A per-run vector (or (..., runs) array) repeated over the epochs of each run."""
        return np.repeat(np.asarray(columns), self.counts, axis=-1)

    def expand(self) -> np.ndarray:
        """The (trials, epochs) array."""
        return self.expand_columns(self.values)

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        out = self.expand()
        return out if dtype is None else out.astype(dtype, copy=False)

    def __getitem__(self, key):
        if isinstance(key, slice):
            return HeldSeries(self.values[key], self.starts, self.n_epochs)
        return self.expand()[key]

    def same_runs(self, other: HeldSeries) -> bool:
        """Whether ``other`` holds its values over the same runs of the same epochs."""
        return self.n_epochs == other.n_epochs and np.array_equal(self.starts, other.starts)
