"""C/N0 and noise-power estimation with the moments (M2M4) estimator.

For prompt samples ``P = a e^{j phi} + n`` with ``n ~ CN(0, s2)``:
``m2 = E|P|^2 = a^2 + s2`` and ``m4 = E|P|^4 = a^4 + 4 a^2 s2 + 2 s2^2``,
so ``Pd = sqrt(2 m2^2 - m4)`` estimates the signal power ``a^2`` and
``Pn = m2 - Pd`` the noise power ``s2``; ``C/N0 = Pd / (Pn Ts)``.
This is the estimator of GNSS-SDR's ``cn0_m2m4_estimator`` (reference notes
§3.3).  It is insensitive to the carrier phase, so it needs no loop lock.

Under scintillation the "signal power" is ``A^2 rho^2`` averaged over the
window, which is what an adaptive R should follow.  When ``2 m2^2 < m4``
(a deep fade or too few samples) the signal power is floored at
``floor_fraction * m2``.  The scalar formulas live once, in
:mod:`.formulas` (the trackers' kernels use them too); the functions here
are their vectorised (ufunc) forms.
"""

from __future__ import annotations

import numpy as np

from . import formulas
from .window import SlidingSums

#: epochs before the first M2M4 estimate (the prior is used until then) and the
#: signal-power floor as a fraction of m2; shared by the estimators and every tracker kernel
M2M4_MIN_EPOCHS = 10
M2M4_FLOOR = 1e-3


def m2m4(prompts: np.ndarray, axis: int = -1, floor_fraction: float = M2M4_FLOOR) -> tuple[np.ndarray, np.ndarray]:
    """Batch (signal power, noise power) from the moments along ``axis``."""
    p2 = np.abs(prompts) ** 2
    m2 = p2.mean(axis=axis)
    m4 = (p2**2).mean(axis=axis)
    return _split(m2, m4, floor_fraction)


def _split(m2: np.ndarray, m4: np.ndarray, floor_fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """Array form of :func:`.formulas.m2m4_split`."""
    pd = formulas.m2m4_signal_power_ufunc(m2, m4, float(floor_fraction))
    return pd, m2 - pd


def cn0_from_powers(signal_power: np.ndarray, noise_power: np.ndarray, ts: float) -> np.ndarray:
    """C/N0 in linear Hz (:func:`.formulas.cn0_from_powers`)."""
    return formulas.cn0_from_powers_ufunc(signal_power, noise_power, float(ts))


def to_dbhz(cn0: np.ndarray) -> np.ndarray:
    return 10.0 * np.log10(cn0)


class StreamingM2M4:
    """M2M4 over the last ``window`` prompts, one estimate per trial and epoch.

    Until the window has ``min_epochs`` samples, the prior values given at
    construction are returned.
    """

    def __init__(self, n_trials: int, window: int, *, prior_signal: float, prior_noise: float, min_epochs: int = M2M4_MIN_EPOCHS, floor_fraction: float = M2M4_FLOOR):
        self.sums = SlidingSums(n_trials, 2, window)
        self.min_epochs = min_epochs
        self.floor_fraction = floor_fraction
        self.prior = (np.full(n_trials, float(prior_signal)), np.full(n_trials, float(prior_noise)))

    def update(self, prompt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p2 = np.abs(prompt) ** 2
        sums, count = self.sums.push(np.stack([p2, p2**2], axis=-1))
        if count < self.min_epochs:
            return self.prior
        return _split(sums[:, 0] / count, sums[:, 1] / count, self.floor_fraction)
