"""Third-order PLL loop filter (Kaplan & Hegarty): bilinear-transform integrators and the NCO step.

``w0 = Bn / 0.7845``; gains ``T w0^3``, ``a3 w0^2``, ``b3 w0`` with ``a3 = 1.1``,
``b3 = 2.4``: :func:`pll_constants`; one loop-filter and NCO step: :func:`pll_step`.
"""

from __future__ import annotations

from numba import njit

__all__ = ["PLL_A3", "PLL_B3", "PLL_BN_PER_W0", "pll_constants", "pll_step"]

PLL_A3, PLL_B3, PLL_BN_PER_W0 = 1.1, 2.4, 0.7845


@njit(cache=True)
def pll_constants(bandwidth_hz, ts):
    """Gains of the bilinear loop filter: (T w0^3, a3 w0^2, b3 w0), w0 = Bn / 0.7845."""
    w0 = bandwidth_hz / PLL_BN_PER_W0
    return ts * w0**3, PLL_A3 * w0**2, PLL_B3 * w0


@njit(cache=True)
def pll_step(phase, v, w, e, k3, k2, k1, ts):
    """One loop-filter and NCO step; works on scalars and (trial) arrays.

    ``w_k = w_{k-1} + T w0^3 e``, ``v_k = v_{k-1} + T ((w_k + w_{k-1})/2 + a3 w0^2 e)``,
    ``f = (v_k + v_{k-1})/2 + b3 w0 e``, next phase ``phase + f T``.
    """
    w_new = w + k3 * e
    v_new = v + ts * (0.5 * (w_new + w) + k2 * e)
    f = 0.5 * (v_new + v) + k1 * e
    return phase + f * ts, v_new, w_new
