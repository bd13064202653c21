"""Cornell Scintillation Model (CSM): synthetic complex scintillation gain.

Follows Humphreys et al. (2009), "Simulating ionosphere-induced scintillation
for testing GPS receiver phase tracking loops" (ref. [55] of Vila-Valls 2018),
as implemented in the authors' own ``scintModel04.m``:

1. Rice factor from S4 through the Nakagami-m match
   ``m = max(1, 1/S4^2)``, ``K = sqrt(m^2 - m) / (m - sqrt(m^2 - m))``.
2. Complex white Gaussian noise at ``Ts/Nspa`` through a 2nd-order digital
   Butterworth low-pass (``scipy.signal.butter(2, Wn)``: bilinear transform
   with pre-warping, as MATLAB's ``butter``) with cut-off
   ``fc = beta0 / (sqrt(2) pi tau0)``, ``beta0 = 1.23964643681047``, which
   makes ``tau0`` the 1/e decorrelation time of the diffuse field ``xi``
   (filtered as ``scipy.signal.lfilter`` filters it, by :func:`.iir.lfilter`:
   its values, compiled).
3. Line of sight ``zbar = sqrt(2 sigma_xi^2 K)`` with
   ``sigma_xi^2 = mean(|xi|^2)/2``; ``z = zbar + xi`` normalised so that
   ``mean |z|^2 = 1``.
4. The output is the integrate-and-dump average of each block of ``Nspa``
   sub-samples (what a correlator sees, ``zScintA``); point samples
   (``zScint``) are available too.

Range of S4.  ``m = max(1, 1/S4^2)`` caps the Nakagami-m at 1 (Rayleigh,
``K = 0``): every S4 >= 1 gives the S4 = 1 field, so the CSM realises only
``0 < S4 <= 1`` (:data:`S4_MAX`).  The generators refuse a larger S4
(:func:`check_s4`) instead of returning an S4 = 1 field labelled otherwise;
the config schema (``$defs/s4``) and :mod:`scintrack.validity` refuse it
before anything runs.  (An S4 > 1, focusing, would need another model, e.g.
Nakagami-m with m < 1, which the CSM is not; we add none.)
:func:`rice_k_from_s4` keeps the toolkit's formula with its clamp.

Choices of ours (documented in ``docs/modelling-choices.md``):

* Seeding: one independent ``SeedSequence`` stream per (dataset, trial)
  (the original uses MATLAB's global generator).
* Warm-up: the Butterworth filter starts from rest, so the first few ``tau0``
  of the diffuse field have too little power.  We generate ``warmup`` extra
  output samples and drop them before the normalisation step.  Set
  ``warmup=0`` to get the original behaviour.
* The time-varying variant (Case IV of Vila-Valls 2018) filters one noise
  stream with piecewise-constant Butterworth coefficients (the filter state is
  carried across the switch) and normalises each segment by the filter's
  theoretical output power, so that ``E|z|^2 = 1`` in every segment.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..estimators.s4 import s4_index  # noqa: F401  (S4 lives in estimators.s4; re-exported)
from ..seeding import rng_for
from . import row_blocks as _row_blocks
from .row_blocks import row_blocks

BETA0 = 1.23964643681047
#: the largest S4 the CSM realises (m = max(1, 1/S4^2) >= 1: Rician, Rayleigh at S4 = 1)
S4_MAX = 1.0
NSPA_DEFAULT = 8


def rice_k_from_s4(s4: float | np.ndarray) -> np.ndarray:
    """Rice K factor matching the Nakagami-m distribution with index ``S4``."""
    s4 = np.asarray(s4, dtype=float)
    if np.any(s4 <= 0):
        raise ValueError("S4 must be > 0")
    m = np.maximum(1.0, 1.0 / s4**2)
    root = np.sqrt(m**2 - m)
    return root / (m - root)


def check_s4(s4: float) -> float:
    """``s4`` if the CSM realises it (``0 < S4 <= S4_MAX``), else a ValueError naming the fix."""
    s4 = float(s4)
    if not 0.0 < s4 <= S4_MAX:
        raise ValueError(
            f"S4 {s4:g} is outside 0 < S4 <= {S4_MAX:g}, what the CSM generator realises (Nakagami/Rician m >= 1); "
            "use 0 < S4 <= 1 in config/config.yaml or your overlay"
        )
    return s4


def cutoff_hz(tau0: float) -> float:
    """Butterworth cut-off ``fc = beta0 / (sqrt(2) pi tau0)`` in Hz."""
    if tau0 <= 0:
        raise ValueError("tau0 must be > 0")
    return BETA0 / (np.sqrt(2.0) * np.pi * tau0)


def butterworth(tau0: float, ts_sub: float) -> tuple[np.ndarray, np.ndarray]:
    """Digital 2nd-order Butterworth ``(b, a)`` for the diffuse field at ``ts_sub``."""
    wn = cutoff_hz(tau0) / (0.5 / ts_sub)
    if not 0 < wn < 1:
        raise ValueError(
            f"tau0={tau0} s is too short for the sub-sample period {ts_sub} s "
            "(cut-off above Nyquist); use a smaller Ts or a larger Nspa"
        )
    from scipy import signal  # imported where used: keeps importing the package (DAG parsing) light
    b, a = signal.butter(2, wn)
    return b, a


def diffuse_field_acf(lag_s: np.ndarray, tau0: float) -> np.ndarray:
    """Normalised autocorrelation of the diffuse field of the analogue model.

    ``R(tau) = exp(-b|tau|) [cos(b tau) + sin(b|tau|)]`` with ``b = beta0/tau0``;
    ``R(tau0) = 1/e`` by construction of ``beta0``.
    """
    x = BETA0 * np.abs(np.asarray(lag_s, dtype=float)) / tau0
    return np.exp(-x) * (np.cos(x) + np.sin(x))


def wrapped_phase(theta: np.ndarray) -> np.ndarray:
    """The CSM phase as a receiver sees it (readings R2/R5 of the Vila-Valls simulation): ``angle(exp(j theta))``.

    numpy's own route, kept as it is: this phase is the trackers' input, and a
    closed loop turns any rounding change into a different run, so it is not
    :func:`scintrack.experiments.metrics.wrap` (a whole-cycle reduction that
    agrees to the last place only).
    """
    return np.angle(np.exp(1j * np.asarray(theta)))


@dataclass(frozen=True)
class CsmRealisation:
    """Complex scintillation gain ``z`` with shape (trials, epochs)."""

    z: np.ndarray
    ts: float

    @property
    def rho(self) -> np.ndarray:
        """Scintillation amplitude ``|z|``."""
        return np.abs(self.z)

    @property
    def theta(self) -> np.ndarray:
        """Scintillation phase ``unwrap(angle(z))`` in rad, along time."""
        return np.unwrap(np.angle(self.z), axis=-1)

    def polar(self) -> tuple[np.ndarray, np.ndarray]:
        """``(rho, theta)`` computed a few rows at a time (:mod:`.row_blocks`: small temporaries, the same bits)."""
        z = self.z
        if z.ndim != 2:
            return self.rho, self.theta
        rho = np.empty(z.shape)
        theta = np.empty(z.shape)
        for lo, hi in row_blocks(z.shape[0], 16 * z.shape[-1]):
            rows = CsmRealisation(z=z[lo:hi], ts=self.ts)  # the same definitions as .rho and .theta, on a block of rows
            rho[lo:hi], theta[lo:hi] = rows.rho, rows.theta
        return rho, theta

    @property
    def time(self) -> np.ndarray:
        return np.arange(self.z.shape[-1]) * self.ts


def _white_noise(seed: int, name: str, trials: Sequence[int], n: int) -> np.ndarray:
    """Unit-variance-per-component complex noise, one independent stream per trial."""
    out = np.empty((len(trials), n), dtype=complex)
    for row, trial in enumerate(trials):
        rng = rng_for(seed, name, trial)
        out[row].real = rng.standard_normal(n)
        out[row].imag = rng.standard_normal(n)
    return out


def _decimate(z_sub: np.ndarray, nspa: int, output: str) -> np.ndarray:
    n_out = z_sub.shape[-1] // nspa
    blocks = z_sub[..., : n_out * nspa].reshape(z_sub.shape[:-1] + (n_out, nspa))
    if output == "average":
        return blocks.mean(axis=-1)
    if output == "point":
        return blocks[..., 0]
    raise ValueError(f"output must be 'average' or 'point', got {output!r}")


def generate_csm(
    *,
    seed: int,
    name: str,
    trials: Sequence[int],
    n_epochs: int,
    ts: float,
    s4: float,
    tau0: float,
    nspa: int = NSPA_DEFAULT,
    warmup: int = 0,
    output: str = "average",
) -> CsmRealisation:
    """Stationary CSM realisations, one row per trial index in ``trials``.

    Trial ``k`` is the same whether it is generated alone or in a batch.
    """
    if n_epochs <= 0:
        raise ValueError("n_epochs must be > 0")
    k = float(rice_k_from_s4(check_s4(s4)))
    ts_sub = ts / nspa
    b, a = butterworth(tau0, ts_sub)
    n_sub = (n_epochs + warmup) * nspa
    from . import iir  # imported where used (numba): keeps importing the package (DAG parsing) light

    trials = list(trials)
    z = np.empty((len(trials), n_epochs), dtype=complex)
    for lo, hi in filter_chunks(len(trials), n_sub):  # streamed: every step below is row-wise
        filtered = iir.lfilter(b, a, _white_noise(seed, name, trials[lo:hi], n_sub))  # scipy.signal.lfilter's values
        for r0, r1 in trial_chunks(hi - lo, n_sub):  # the rest in the budget's blocks: small temporaries
            xi = filtered[r0:r1, warmup * nspa :]
            sigma2 = 0.5 * np.mean(np.abs(xi) ** 2, axis=-1, keepdims=True)
            zbar = np.sqrt(2.0 * sigma2 * k)
            z_sub = zbar + xi
            z_sub = z_sub / np.sqrt(np.mean(np.abs(z_sub) ** 2, axis=-1, keepdims=True))
            z[lo + r0 : lo + r1] = _decimate(z_sub, nspa, output)
    return CsmRealisation(z=z, ts=ts)


def trial_chunks(n_trials: int, n_sub: int, budget_bytes: int | None = None) -> list[tuple[int, int]]:
    """Row blocks ``[lo, hi)`` whose complex sub-sample arrays (``n_sub`` samples per row) fit the budget.

    Generation streams over these blocks (:mod:`.row_blocks`; the budget
    defaults to its ``CHUNK_BYTES``, 8 MB: a 500-s scenario one row at a time);
    the values do not depend on the blocking, since every operation is per
    row (one seed stream, one filter pass, one normalisation per trial).
    Blocks of 64 MB would make a 500-s cycle-slip shard ~250 MB larger and
    cost it 2-3 s of page faults.
    """
    return row_blocks(n_trials, 16 * max(n_sub, 1), budget_bytes)


def filter_chunks(n_trials: int, n_sub: int) -> list[tuple[int, int]]:
    """Row blocks for the diffuse field's white noise and its filter: :func:`trial_chunks`, but at least
    ``iir.GROUP`` rows (:mod:`.iir`), which the compiled filter runs side by side (~2.5x faster than one at a time;
    a 500-s scenario's row is 6.5 MB, so the white noise and its filtered copy hold 4 rows, ~40 MB more
    than one row, while the steps after the filter go on in :func:`trial_chunks`' blocks).  Row-wise
    too: the values do not depend on it."""
    from .iir import GROUP

    row = 16 * max(n_sub, 1)
    return row_blocks(n_trials, row, max(_row_blocks.CHUNK_BYTES, GROUP * row))  # the budget read at call time


@dataclass(frozen=True)
class Segment:
    """One piece of a piecewise-constant scintillation profile."""

    start_s: float
    s4: float
    tau0: float


def _filter_power(b: np.ndarray, a: np.ndarray, tau0: float, ts_sub: float) -> float:
    """Output power gain ``sum h^2`` of the digital filter (impulse response)."""
    n = int(np.ceil(40.0 * tau0 / ts_sub)) + 16
    impulse = np.zeros(n)
    impulse[0] = 1.0
    from scipy import signal  # imported where used: keeps importing the package (DAG parsing) light
    h = signal.lfilter(b, a, impulse)
    return float(np.sum(h**2))


def generate_csm_profile(
    *,
    seed: int,
    name: str,
    trials: Sequence[int],
    n_epochs: int,
    ts: float,
    segments: Sequence[Segment],
    nspa: int = NSPA_DEFAULT,
    warmup: int = 0,
    output: str = "average",
) -> tuple[CsmRealisation, np.ndarray, np.ndarray]:
    """CSM with piecewise-constant (S4, tau0); returns (z, S4(t), tau0(t))."""
    if not segments or segments[0].start_s != 0:
        raise ValueError("a scintillation profile must start with a segment at start_s = 0")
    starts = [s.start_s for s in segments]
    if any(b <= a for a, b in zip(starts, starts[1:])):
        raise ValueError("profile segments must have strictly increasing start_s")
    ts_sub = ts / nspa
    n_sub = (n_epochs + warmup) * nspa
    los = np.empty(n_sub)
    diffuse_scale = np.empty(n_sub)
    bounds = [warmup * nspa + int(round(s.start_s / ts_sub)) for s in segments]
    bounds[0] = 0
    bounds.append(n_sub)
    from . import iir  # imported where used (numba): keeps importing the package (DAG parsing) light

    pieces = []  # (lo, hi, b, a) of every non-empty segment; LOS and diffuse scale per sub-sample
    for seg, lo, hi in zip(segments, bounds[:-1], bounds[1:]):
        if hi <= lo:
            continue
        b, a = butterworth(seg.tau0, ts_sub)
        k = float(rice_k_from_s4(check_s4(seg.s4)))
        power = 2.0 * _filter_power(b, a, seg.tau0, ts_sub)
        los[lo:hi] = np.sqrt(k / (1.0 + k))
        diffuse_scale[lo:hi] = np.sqrt(1.0 / ((1.0 + k) * power))
        pieces.append((lo, hi, b, a))
    trials = list(trials)
    z = np.empty((len(trials), n_epochs), dtype=complex)
    for c0, c1 in filter_chunks(len(trials), n_sub):  # streamed, row-wise (see filter_chunks)
        w = _white_noise(seed, name, trials[c0:c1], n_sub)
        xi = np.empty_like(w)
        zi = np.zeros((w.shape[0], 2), dtype=complex)
        for lo, hi, b, a in pieces:  # one filter state carried across the switches (scipy.signal.lfilter's values)
            xi[:, lo:hi], zi = iir.lfilter(b, a, w[:, lo:hi], zi=zi)
        del w
        for r0, r1 in trial_chunks(c1 - c0, n_sub):  # small temporaries
            z[c0 + r0 : c0 + r1] = _decimate((los + diffuse_scale * xi[r0:r1])[:, warmup * nspa :], nspa, output)
    t = np.arange(n_epochs) * ts
    idx = np.searchsorted(starts, t, side="right") - 1
    s4_t = np.array([segments[i].s4 for i in idx])
    tau0_t = np.array([segments[i].tau0 for i in idx])
    return CsmRealisation(z=z, ts=ts), s4_t, tau0_t
