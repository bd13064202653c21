"""Bit synchronisation from the sign changes of 1-ms prompts (scintrack.signals.gps.bit_sync)."""

from __future__ import annotations

import numpy as np
import pytest

from scintrack.signals.gps.bit_sync import BIT_MS, bit_sync, sign_changes


def _prompts(offset: int, n_ms: int, seed: int, flips=()):
    """Noise-free in-phase prompts of random 20-ms bits whose edges fall on epochs ``offset + 20 j``, rotated by a
    constant phase (what a Costas loop leaves), with the signs of the epochs in ``flips`` inverted."""
    rng = np.random.default_rng(seed)
    bit_of_epoch = (np.arange(n_ms) - offset) // BIT_MS
    bits = rng.choice([-1.0, 1.0], bit_of_epoch.max() - bit_of_epoch.min() + 1)[bit_of_epoch - bit_of_epoch.min()]
    y = bits * (1.0 + 0.1 * rng.standard_normal(n_ms)) * np.exp(0.3j)
    y[list(flips)] *= -1.0
    transitions = np.flatnonzero(bits[1:] != bits[:-1]) + 1
    return y, transitions


def test_offset_and_edges_are_the_data_transitions():
    y, transitions = _prompts(offset=7, n_ms=400, seed=1)
    sync = bit_sync(y)
    assert sync.offset == 7
    assert sync.confidence == 1.0
    np.testing.assert_array_equal(sync.edges, transitions)
    assert transitions.size >= 5  # the draw has transitions to find
    np.testing.assert_array_equal(sync.boundaries, np.arange(7, 400, BIT_MS))
    assert sync.histogram.sum() == sync.n_changes == transitions.size


def test_noise_flips_lower_the_confidence_but_not_the_offset():
    """A sign flip inside a bit adds two changes off the offset: confidence = transitions / (transitions + 2 flips)."""
    flips = (35, 95, 250)  # neither of the two changes of a flip on the offset
    y, transitions = _prompts(offset=13, n_ms=400, seed=2, flips=flips)
    assert all(f % BIT_MS not in (12, 13) for f in flips)
    sync = bit_sync(y)
    assert sync.offset == 13
    assert sync.confidence == pytest.approx(transitions.size / (transitions.size + 2 * len(flips)))
    np.testing.assert_array_equal(sync.edges, transitions)


def test_costas_sign_and_pull_in_are_ignored():
    """Negating every prompt (the Costas ambiguity) changes nothing; changes before ``first_epoch`` are not counted."""
    y, _ = _prompts(offset=4, n_ms=300, seed=3)
    noisy_start = y.copy()
    noisy_start[:60] = np.exp(1j * np.random.default_rng(4).uniform(0, 2 * np.pi, 60))  # a loop still pulling in
    ref = bit_sync(y, first_epoch=60)
    for variant in (-y, noisy_start):
        sync = bit_sync(variant, first_epoch=60)
        assert (sync.offset, sync.confidence) == (ref.offset, ref.confidence) == (4, 1.0)
        np.testing.assert_array_equal(sync.edges, ref.edges)
    assert bit_sync(noisy_start).confidence < 0.9  # counted from epoch 0 the pull-in spoils it
    assert ref.boundaries[0] == 64


def test_no_sign_change_gives_no_offset():
    sync = bit_sync(np.full(100, 1.0 + 0.5j))
    assert sync.offset is None and np.isnan(sync.confidence) and sync.edges.size == 0 and sync.n_changes == 0


def test_sign_changes_and_bad_input():
    np.testing.assert_array_equal(sign_changes(np.array([1.0, 2.0, -1.0, -3.0, 4.0])), [2, 4])
    with pytest.raises(ValueError, match="1-D"):
        bit_sync(np.ones((2, 40)))
    with pytest.raises(ValueError, match="first_epoch"):
        bit_sync(np.ones(40), first_epoch=40)
