"""Prompt-correlator output model (Vila-Valls 2018, eq. 6).

``y_k = A rho_k exp(j (theta_d,k + theta_s,k)) + n_k``, ``n_k ~ CN(0, s2)``
(``s2/2`` per component), with ``A^2 / s2 = C/N0 Ts``: the post-correlation
SNR of a correlator integrating over ``Ts``.  Perfect code alignment and data
wipe-off are assumed, as in the paper; the Doppler residual's sinc loss and
the phase averaging within one integration interval are not modelled (the
trackers work on these samples directly, as in the paper's simulations).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..seeding import rng_for
from .row_blocks import row_blocks


def noise_power(cn0_dbhz: float, ts: float, amplitude: float = 1.0) -> float:
    """Complex noise variance ``s2`` giving ``A^2/s2 = C/N0 Ts``."""
    return amplitude**2 / (10.0 ** (cn0_dbhz / 10.0) * ts)


def complex_noise(seed: int, name: str, trials: Sequence[int], n_epochs: int, power: float) -> np.ndarray:
    out = np.empty((len(trials), n_epochs), dtype=complex)
    scale = np.sqrt(power / 2.0)
    for row, trial in enumerate(trials):
        rng = rng_for(seed, name, trial)
        out[row].real = rng.standard_normal(n_epochs) * scale
        out[row].imag = rng.standard_normal(n_epochs) * scale
    return out


def prompts(theta: np.ndarray, rho: np.ndarray | float, noise: np.ndarray, amplitude: float = 1.0, out: np.ndarray | None = None) -> np.ndarray:
    """Correlator outputs ``amplitude rho exp(j theta) + noise`` for total phase ``theta`` and amplitude gain ``rho``.

    Computed a few rows at a time (:mod:`.row_blocks`), so the temporaries of
    the expression stay small; the values are those of the whole-array
    expression, bit for bit.  ``out`` (complex, the broadcast shape) receives
    the result and may be ``noise`` itself (its rows are read before they are
    written).
    """
    theta, rho, noise = np.asarray(theta, dtype=float), np.asarray(rho, dtype=float), np.asarray(noise)
    shape = np.broadcast_shapes(theta.shape, rho.shape, noise.shape)
    if out is None:
        out = np.empty(shape, dtype=complex)
    if len(shape) != 2:  # not (trials, epochs): one block
        out[...] = amplitude * rho * np.exp(1j * theta) + noise
        return out
    theta, rho, noise = (np.broadcast_to(v, shape) for v in (theta, rho, noise))  # a scalar rho: the same products
    for lo, hi in row_blocks(shape[0], 16 * shape[1]):
        out[lo:hi] = amplitude * rho[lo:hi] * np.exp(1j * theta[lo:hi]) + noise[lo:hi]
    return out
