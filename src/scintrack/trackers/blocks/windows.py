"""The kernels' sliding windows on lanes: ring buffers with running sums, and the M2M4 window.

:func:`window_push_lanes` is :func:`scintrack.estimators.formulas.window_push`
on ``LANES`` ring buffers at once; :func:`m2m4_lanes` pushes each lane's
prompt power ``|P|^2`` and ``|P|^4`` and splits the window means with
:func:`scintrack.estimators.formulas.m2m4_split` (GNSS-SDR's
``cn0_m2m4_estimator``), per lane the arithmetic of the one-trial window.
"""

from __future__ import annotations

from numba import njit

from ...estimators.formulas import m2m4_split
from ...simd import LANES
from ...simd.lanes import lane_load, lane_splat, lane_store

__all__ = ["m2m4_lanes", "window_push_lanes"]

@njit(cache=True)
def window_push_lanes(b1, b2, pos, s1, s2, count, v1, v2):
    """:func:`window_push` on LANES ring buffers at once; returns (pos, count), updates ``s1``, ``s2`` in place.

    ``b1``, ``b2`` (window, LANES): one ring buffer per lane (column); ``s1``,
    ``s2`` (LANES,) their running sums; ``v1``, ``v2`` (LANES,) the values
    pushed.  Per lane the arithmetic of :func:`window_push`: ``s += v - b[pos]``
    and, once per lap, the exact re-sum in index order from 0 (as
    ``ndarray.sum`` in numba).
    """
    L = LANES
    w = b1.shape[0]
    if b1.shape != (w, L) or b2.shape != (w, L) or s1.shape != (L,) or s2.shape != (L,) or v1.shape != (L,) or v2.shape != (L,) or not 0 <= pos < w:
        raise ValueError("window_push_lanes: buffers (window, LANES), sums and values (LANES,), 0 <= pos < window")
    o = pos * L
    a1 = lane_load(v1, 0)
    a2 = lane_load(v2, 0)
    lane_store(s1, 0, lane_load(s1, 0) + (a1 - lane_load(b1, o)))
    lane_store(s2, 0, lane_load(s2, 0) + (a2 - lane_load(b2, o)))
    lane_store(b1, o, a1)
    lane_store(b2, o, a2)
    pos = (pos + 1) % w
    count = min(count + 1, w)
    if pos == 0:
        t1 = lane_splat(0.0)
        t2 = lane_splat(0.0)
        for j in range(w):
            t1 = t1 + lane_load(b1, j * L)
            t2 = t2 + lane_load(b2, j * L)
        lane_store(s1, 0, t1)
        lane_store(s2, 0, t2)
    return pos, count



@njit(cache=True)
def m2m4_lanes(b2, b4, pos, s2, s4, count, yr, yi, p2, p4, min_epochs, prior_signal, prior_noise, floor_fraction, sig, noi):
    """The M2M4 window of the discriminator KFs on lanes; returns (pos, count).

    Pushes ``p2 = yr^2 + yi^2`` (LANES,: each lane's prompt power ``|P|^2``) and
    ``p4 = p2 * p2`` (both written; scratch) into the ring buffers ``b2``, ``b4`` (window, LANES) with running sums ``s2``,
    ``s4`` (LANES,) (:func:`window_push_lanes`), then writes ``sig``, ``noi``
    (LANES,): the priors while ``count < min_epochs``, else :func:`m2m4_split`
    of the window means -- per lane the arithmetic of ``window_push`` and ``m2m4_split``.
    """
    L = LANES
    if yr.shape != (L,) or yi.shape != (L,) or p2.shape != (L,) or p4.shape != (L,) or sig.shape != (L,) or noi.shape != (L,):
        raise ValueError("m2m4_lanes: yr, yi, p2, p4, sig, noi must be (LANES,)")
    vr, vi = lane_load(yr, 0), lane_load(yi, 0)
    lane_store(p2, 0, vr * vr + vi * vi)
    v = lane_load(p2, 0)
    lane_store(p4, 0, v * v)
    pos, count = window_push_lanes(b2, b4, pos, s2, s4, count, p2, p4)
    if count < min_epochs:
        lane_store(sig, 0, lane_splat(prior_signal))
        lane_store(noi, 0, lane_splat(prior_noise))
    else:
        sg, nz = m2m4_split(lane_load(s2, 0) / count, lane_load(s4, 0) / count, floor_fraction)
        lane_store(sig, 0, sg)
        lane_store(noi, 0, nz)
    return pos, count
