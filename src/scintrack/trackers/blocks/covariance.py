"""Covariance safeguards: periodic symmetrisation and the divergence guard's test.

* :func:`symmetrise`: ``P <- (P + P^T) / 2``, against the asymmetry that
  rounding builds up in ``P -= K (P H^T)^T``;
* :func:`covariance_ok`: the cheapest meaningful positive-(semi)definiteness
  test on the (phase, frequency) pair: finite, non-negative variances and a
  2 x 2 minor >= 0; the kernels record the first failing epoch per trial and
  :mod:`scintrack.experiments.guards` turns it into a divergence flag.
"""

from __future__ import annotations

import math

from numba import njit

from ...simd.ufunc import LazyUfunc

__all__ = ["COV_CORRELATION_SLACK", "covariance_ok", "covariance_ok_ufunc", "symmetrise"]

@njit(cache=True)
def symmetrise(P):
    n = P.shape[0]
    for a in range(n):
        for b in range(a + 1, n):
            m = 0.5 * (P[a, b] + P[b, a])
            P[a, b] = m
            P[b, a] = m


#: relative slack of the Cauchy-Schwarz test of :func:`covariance_ok` (rounding of a strongly correlated pair)
COV_CORRELATION_SLACK = 1e-6


def _covariance_ok(paa, pbb, pab):
    """The cheapest meaningful positive-(semi)definiteness test of a covariance, on one pair of states.

    ``paa``, ``pbb``: the variances of the phase and the frequency state;
    ``pab`` their covariance.  Passes when both variances are finite and
    >= 0 and ``pab^2 <= paa pbb (1 + COV_CORRELATION_SLACK)`` (the 2 x 2
    principal minor >= 0, Cauchy-Schwarz): necessary conditions of a positive
    semi-definite P, three loads and a few compares per epoch.  An exact zero
    variance passes (a state known exactly, e.g. the static AEKF-AR's
    dynamics block with P0 = Q = 0); a NaN or inf anywhere in the pair fails
    (every comparison with NaN is false).  The slack allows the rounding of a
    pair correlated to within 1e-6 of 1; a filter that has truly lost positive
    definiteness violates it by orders of magnitude.  Read-only: the kernels
    call it on the updated P and record the first failing epoch per trial
    (``extras["cov_fail_epoch"]``, -1 none), which
    :mod:`scintrack.experiments.guards` turns into a divergence flag.
    """
    if not (paa >= 0.0 and pbb >= 0.0 and paa < math.inf and pbb < math.inf):
        return False
    return pab * pab <= paa * pbb * (1.0 + COV_CORRELATION_SLACK)


covariance_ok = njit(cache=True)(_covariance_ok)
covariance_ok_ufunc = LazyUfunc(_covariance_ok, ["boolean(float64, float64, float64)"])
