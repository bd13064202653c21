"""Compiled (numba) loops that are not trackers: the cycle-slip counter and
the unit phasors of :mod:`scintrack.experiments.metrics`.

The trackers' kernels live in their own modules (:mod:`.pll`, :mod:`.kf`,
:mod:`.aekf_ar`) and are made of the building blocks in :mod:`.blocks`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def cycle_slip_kernel(e, hysteresis, settle):
    """Cycles slipped and slip events per trial (see experiments.metrics)."""
    n, k = e.shape
    two_pi = 2.0 * math.pi
    limit = math.pi + hysteresis
    cycles = np.zeros(n, dtype=np.int64)
    events = np.zeros(n, dtype=np.int64)
    for t in range(n):
        level = np.round(e[t, 0] / two_pi)
        in_event = False
        calm = 0
        for i in range(1, k):
            if abs(e[t, i] - two_pi * level) >= limit:
                new = np.round(e[t, i] / two_pi)
                cycles[t] += int(abs(new - level))
                level = new
                if not in_event:
                    events[t] += 1
                    in_event = True
                calm = 0
            elif in_event:
                calm += 1
                if calm >= settle:
                    in_event = False
    return cycles, events


@njit(cache=True)
def sin_cos_kernel(e, s, c):
    """``s = sin(e)``, ``c = cos(e)`` element by element (1-D, contiguous).

    The same libm calls that numpy's complex ``exp`` makes for a purely
    imaginary argument, so ``c + j s`` equals ``numpy.exp(1j * e)`` bit for
    bit (``tests/test_speed_paths.py``), without the two complex temporaries.
    """
    for i in range(e.size):
        s[i] = math.sin(e[i])
        c[i] = math.cos(e[i])
