"""On-line S4 estimate from the prompt intensity, corrected for thermal noise.

With ``I = |P|^2``, ``P = A rho e^{j theta} + n`` and ``n ~ CN(0, s2)``
independent of the scintillation:

* ``E[I] = S + s2`` with ``S = A^2 E[rho^2]``;
* ``Var[I] = A^4 Var[rho^2] + 2 S s2 + s2^2``.

So ``S4^2 = Var[rho^2]/E[rho^2]^2 = (Var[I] - 2 S s2 - s2^2) / S^2`` with
``S = E[I] - s2``.  The noise power ``s2`` comes from the M2M4 estimator
(:mod:`scintrack.estimators.cn0`) over a longer window, or is given.
Moments are taken over a sliding window of the last ``window`` epochs, with no
detrending (the tracker's input has no slow power trend in our scenarios).
This is the estimator the AEKF-AR uses to adapt (Vila-Valls 2018, Sec. V-B);
the paper cites [65] without giving one.
"""

from __future__ import annotations

import numpy as np

from .window import SlidingSums


def s4_corrected(mean_i: np.ndarray, var_i: np.ndarray, noise_power: np.ndarray) -> np.ndarray:
    signal = np.maximum(mean_i - noise_power, 1e-12)
    s4sq = (var_i - 2.0 * signal * noise_power - noise_power**2) / signal**2
    return np.sqrt(np.clip(s4sq, 0.0, None))


def s4_batch(prompts: np.ndarray, noise_power: float | np.ndarray, axis: int = -1) -> np.ndarray:
    intensity = np.abs(prompts) ** 2
    return s4_corrected(intensity.mean(axis=axis), intensity.var(axis=axis), np.asarray(noise_power))


class StreamingS4:
    """Noise-corrected S4 over the last ``window`` prompts, per trial."""

    def __init__(self, n_trials: int, window: int, *, prior: float = 0.0, min_epochs: int | None = None):
        self.sums = SlidingSums(n_trials, 2, window)
        self.min_epochs = min_epochs if min_epochs is not None else window
        self.prior = np.full(n_trials, float(prior))

    def update(self, prompt: np.ndarray, noise_power: np.ndarray) -> np.ndarray:
        i = np.abs(prompt) ** 2
        sums, count = self.sums.push(np.stack([i, i**2], axis=-1))
        if count < self.min_epochs:
            return self.prior
        mean = sums[:, 0] / count
        var = np.maximum(sums[:, 1] / count - mean**2, 0.0)
        return s4_corrected(mean, var, noise_power)
