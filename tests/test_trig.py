"""The trackers' sine, cosine and arctangent (:mod:`scintrack.trackers.trig`): accuracy against libm, the
same bits on a number and on a lane, the edge cases the discriminators meet."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from numba import njit

from scintrack.simd import LANES
from scintrack.simd.lanes import lane_load, lane_store
from scintrack.trackers import trig


def ulps(a, b) -> np.ndarray:
    """Distance in units in the last place between float64 arrays (same sign convention as IEEE ordering)."""
    ia = np.asarray(a, dtype=float).view(np.int64)
    ib = np.asarray(b, dtype=float).view(np.int64)
    ia = np.where(ia < 0, np.int64(-(2**63)) - ia, ia)
    ib = np.where(ib < 0, np.int64(-(2**63)) - ib, ib)
    return np.abs(ia - ib)


@njit(cache=True)
def _sincos_all(x):
    s = np.empty_like(x)
    c = np.empty_like(x)
    for i in range(x.size):
        s[i], c[i] = trig.sincos(x[i])
    return s, c


@njit(cache=True)
def _pairwise(f, a, b):
    """``f(a[i], b[i])`` for every i (f: trig.atan2 or trig.atan)."""
    out = np.empty_like(a)
    for i in range(a.size):
        out[i] = f(a[i], b[i])
    return out


def _atan2_all(y, x):
    return _pairwise(trig.atan2, y, x)


def _atan_all(q, i_):
    return _pairwise(trig.atan, q, i_)


@njit(cache=True)
def _lanes_all(x, y):
    """sincos(x), atan2(y, x), atan(y, x) on Lanes, LANES values at a time."""
    s = np.empty_like(x)
    c = np.empty_like(x)
    a2 = np.empty_like(x)
    a1 = np.empty_like(x)
    for o in range(0, x.size, LANES):
        sv, cv = trig.sincos(lane_load(x, o))
        lane_store(s, o, sv)
        lane_store(c, o, cv)
        lane_store(a2, o, trig.atan2(lane_load(y, o), lane_load(x, o)))
        lane_store(a1, o, trig.atan(lane_load(y, o), lane_load(x, o)))
    return s, c, a2, a1


@pytest.mark.parametrize("top", [1.0, 10.0, 1e3, 1e6, 1e8])
def test_sincos_is_within_one_ulp_of_libm(top):
    rng = np.random.default_rng(int(top))
    x = rng.uniform(-top, top, 100_000)
    s, c = _sincos_all(x)
    ds, dc = ulps(s, np.sin(x)), ulps(c, np.cos(x))
    assert ds.max() <= 1 and dc.max() <= 1, (ds.max(), dc.max())
    assert (ds == 0).mean() > 0.9 and (dc == 0).mean() > 0.9  # a sloppy reduction or polynomial is far off this


def test_sincos_near_multiples_of_half_pi():
    """The reduction's hard cases: x next to k pi/2, where x - k pi/2 cancels to a few bits of x."""
    pi = trig._machin_pi()
    ks = np.array([1, 2, 3, 4, 7, 100, 12345, 10**6, 6 * 10**7])
    x = np.array([float(k * pi / 2) for k in ks])
    x = np.concatenate([x, np.nextafter(x, 0), np.nextafter(x, np.inf)])
    s, c = _sincos_all(x)
    assert ulps(s, np.sin(x)).max() <= 1 and ulps(c, np.cos(x)).max() <= 1


def test_sincos_exact_values_and_non_finite():
    s, c = _sincos_all(np.array([0.0, -0.0, 1e-300, np.nan, np.inf, -np.inf]))
    assert s[0] == 0.0 and c[0] == 1.0 and c[1] == 1.0 and s[2] == 1e-300 and c[2] == 1.0
    assert np.isnan(s[3:]).all() and np.isnan(c[3:]).all()


def test_sin_squared_plus_cos_squared():
    x = np.random.default_rng(3).uniform(-1e7, 1e7, 50_000)
    s, c = _sincos_all(x)
    assert np.abs(s * s + c * c - 1.0).max() < 4e-16


def test_atan2_is_within_two_ulp_of_libm_in_every_quadrant():
    rng = np.random.default_rng(5)
    y = rng.standard_normal(200_000) * 10.0 ** rng.uniform(-4, 4, 200_000)
    x = rng.standard_normal(200_000) * 10.0 ** rng.uniform(-4, 4, 200_000)
    d = ulps(_atan2_all(y, x), np.arctan2(y, x))
    assert d.max() <= 2 and (d == 0).mean() > 0.5, (d.max(), (d == 0).mean())
    # the switch at tan(pi/8) and the octant boundaries
    t = np.array([math.tan(math.pi / 8), 1.0, 1 / math.tan(math.pi / 8)])
    t = np.concatenate([t, np.nextafter(t, 0), np.nextafter(t, 9)])
    for sy, sx in [(1, 1), (1, -1), (-1, 1), (-1, -1)]:
        assert ulps(_atan2_all(sy * t, sx * np.ones_like(t)), np.arctan2(sy * t, sx * np.ones_like(t))).max() <= 2


def test_atan2_edge_cases():
    y = np.array([0.0, 0.0, 1.0, -1.0, np.inf, 1.0, np.nan, 1.0, 2.0, -3.0])
    x = np.array([0.0, -1.0, 0.0, 0.0, 1.0, np.inf, 1.0, np.nan, 2.0, -3.0])
    got = _atan2_all(y, x)
    want = np.array([0.0, math.pi, math.pi / 2, -math.pi / 2, math.pi / 2, 0.0, np.nan, np.nan, math.pi / 4, -3 * math.pi / 4])
    assert np.array_equal(got, want, equal_nan=True)


def test_atan_is_atan_of_the_quotient():
    rng = np.random.default_rng(7)
    q, i_ = rng.standard_normal(100_000), rng.standard_normal(100_000)
    assert ulps(_atan_all(q, i_), np.arctan(q / i_)).max() <= 2
    got = _atan_all(np.array([1.0, -1.0, 0.0, 1.0, -1.0]), np.array([0.0, 0.0, 0.0, -0.0, -0.0]))
    assert np.array_equal(got, [math.pi / 2, -math.pi / 2, 0.0, math.pi / 2, -math.pi / 2])  # I = 0: +-pi/2 by Q


def test_lanes_give_the_bits_of_the_numbers():
    rng = np.random.default_rng(11)
    n = 40 * LANES
    x = rng.uniform(-1e6, 1e6, n) * 10.0 ** rng.uniform(-8, 0, n)
    y = rng.standard_normal(n) * 10.0 ** rng.uniform(-3, 3, n)
    x[:6] = [0.0, np.nan, np.inf, -np.inf, 1e-300, -0.0]
    y[6:10] = [0.0, np.nan, np.inf, -0.0]
    s, c, a2, a1 = _lanes_all(x, y)
    s0, c0 = _sincos_all(x)
    for got, want in ((s, s0), (c, c0), (a2, _atan2_all(y, x)), (a1, _atan_all(y, x))):
        assert np.array_equal(got.view(np.uint64), want.view(np.uint64))


def test_pi_and_its_pieces():
    pi = trig._machin_pi()
    assert abs(pi - Fraction("3.14159265358979323846264338327950288419716939937510582097494459")) < Fraction(1, 10**62)
    pieces = sum(Fraction(*p.as_integer_ratio()) for p in (trig.PIO2_1, trig.PIO2_2, trig.PIO2_3, trig.PIO2_4))
    assert abs(pieces - pi / 2) < Fraction(1, 2**130)
    for p in (trig.PIO2_1, trig.PIO2_2, trig.PIO2_3):  # 27 significant bits: k * piece exact for |k| < 2**26
        m = Fraction(*p.as_integer_ratio())
        while m.denominator > 1:
            m *= 2
        assert int(m).bit_length() - (int(m) & -int(m)).bit_length() + 1 <= 27
