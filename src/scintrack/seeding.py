"""Deterministic random streams split with ``numpy.random.SeedSequence``.

Every random draw in the project comes from :func:`rng_for`, keyed by the
root seed of the config, a stable name of the dataset (or experiment) and the
trial index.  The stream of trial *k* therefore never depends on how many
trials are generated together, on the number of cores, or on which jobs ran
before.
"""

from __future__ import annotations

import hashlib

import numpy as np


def stable_key(name: str) -> int:
    """A 32-bit integer derived from ``name`` that is the same on every machine."""
    return int.from_bytes(hashlib.sha256(name.encode("utf-8")).digest()[:4], "little")


def seed_sequence(root_seed: int, name: str, trial: int) -> np.random.SeedSequence:
    """The SeedSequence of one (dataset or experiment, trial) pair."""
    if root_seed < 0 or trial < 0:
        raise ValueError(f"seeds and trial indices must be >= 0 (got seed={root_seed}, trial={trial})")
    return np.random.SeedSequence(int(root_seed), spawn_key=(stable_key(name), int(trial)))


def rng_for(root_seed: int, name: str, trial: int) -> np.random.Generator:
    """The random generator of one (dataset or experiment, trial) pair."""
    return np.random.Generator(np.random.PCG64(seed_sequence(root_seed, name, trial)))
