"""Software-receiver front end for IQ recordings: FFT acquisition and a 1-ms correlator with a local replica.

Used to cross-check the synthesised recordings (:mod:`.iq`) against the
correlator-level model of the reference notes (gps-lnav-mm.md Sec. 2.2):
with a replica aligned to the truth, the prompt is ``A d e^{j dphi}`` plus
complex noise of variance ``N0_eff / T``, so ``|P|^2`` over the noise
variance is ``(C/N0)_eff T``.

* :func:`acquire` is the parallel code-phase search (Borre et al., *A
  Software-Defined GPS and Galileo Receiver*, 2007, ch. 6): for each Doppler
  bin the carrier is wiped off and the circular correlation with the local
  code is computed as ``IFFT(FFT(x) conj(FFT(c)))`` (scipy.fft), over
  ``n_coherent_ms`` ms, and ``n_noncoherent`` such blocks are summed in
  power.  The acquisition replica runs at the nominal 1.023 Mcps (code
  Doppler over a few ms is < 0.02 chip).  ``peak_ratio`` is the highest
  correlation power over the highest one in the same Doppler bin outside +-1
  chip of the peak (SoftGNSS' test statistic); the caller picks a threshold.
* :func:`correlate` is an open-loop correlator for a constant Doppler: the
  local code phase is ``theta(n) = theta_0 + f_code n / fs`` with the
  carrier-aided ``f_code = 1.023e6 (1 + f_D/f_L1)``, the chip is
  ``c[floor(theta) mod 1023]`` (nearest-chip sampling at fs, as the
  synthesiser does) and the carrier replica is ``exp(j(phi_0 + 2 pi f_D n/fs))``.
  Each integration spans one local code period, from one code epoch to the
  next (the first epoch at or after sample 0), as a tracking receiver does:
  LNAV bit edges fall on code epochs, so no prompt straddles a bit edge when
  the replica is aligned.  A period lasts ``1023 / f_code`` (1 ms up to
  3e-6) and holds 12487 or 12488 samples at 12.5 MS/s.  Outputs are sample
  means (sum / number of samples), so the aligned prompt's signal part is the
  amplitude ``A`` itself.  Early and late replicas are the code advanced and
  delayed by ``spacing/2`` chips, so with ``dtau = tau_true - tau_hat``,
  ``|L| > |E|`` when ``dtau > 0`` (the notes' sign convention).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import fft

from .ca_code import CHIP_RATE_HZ, CHIPS, ca_code
from .iq import MS, code_rate_hz

#: periods processed per chunk in :func:`correlate` (bounds memory)
CHUNK_PERIODS = 50


@dataclass(frozen=True)
class Acquisition:
    """Acquisition result: code phase of the received code at sample 0, Doppler bin, peak ratio."""

    code_phase_chips: float
    doppler_hz: float
    peak_ratio: float


@dataclass(frozen=True)
class Correlations:
    """Per-code-period correlator outputs; ``start_index``/``n_samples`` locate each integration."""

    prompt: np.ndarray
    early: np.ndarray | None
    late: np.ndarray | None
    start_index: np.ndarray
    n_samples: np.ndarray


def _check_common(samples: np.ndarray, fs: float) -> np.ndarray:
    samples = np.asarray(samples)
    if samples.ndim != 1:
        raise ValueError(f"samples must be a 1-D array of complex baseband samples (got shape {samples.shape})")
    if not fs > 0:
        raise ValueError(f"fs must be > 0 Hz (got {fs})")
    return samples


def local_code(prn: int, fs: float, n: int, code_phase_chips: float, doppler_hz: float = 0.0, start: int = 0) -> np.ndarray:
    """Replica chips (+-1, float32) of samples ``start .. start + n - 1``: ``c[floor(theta_0 + f_code k / fs) mod 1023]``."""
    theta = code_phase_chips + code_rate_hz(doppler_hz) / fs * np.arange(start, start + n)
    return ca_code(prn).astype(np.float32)[np.floor(theta).astype(np.int64) % CHIPS]


def acquire(samples: np.ndarray, fs: float, prn: int, doppler_bins_hz, n_coherent_ms: int = 1, n_noncoherent: int = 5) -> Acquisition:
    """Parallel code-phase search over ``doppler_bins_hz`` on the first ``n_coherent_ms * n_noncoherent`` ms."""
    samples = _check_common(samples, fs)
    bins = np.atleast_1d(np.asarray(doppler_bins_hz, dtype=float))
    if bins.ndim != 1 or bins.size == 0:
        raise ValueError("doppler_bins_hz must be a non-empty 1-D sequence of Doppler bins (Hz)")
    if n_coherent_ms < 1 or n_noncoherent < 1:
        raise ValueError(f"n_coherent_ms and n_noncoherent must be >= 1 (got {n_coherent_ms}, {n_noncoherent})")
    n = int(round(n_coherent_ms * MS * fs))
    if samples.size < n * n_noncoherent:
        raise ValueError(f"acquisition needs {n * n_noncoherent} samples ({n_coherent_ms} ms x {n_noncoherent}) but got {samples.size}")
    blocks = samples[: n * n_noncoherent].reshape(n_noncoherent, n)
    code_spectrum = np.conj(fft.fft(local_code(prn, fs, n, 0.0)))
    t = np.arange(n) / fs
    power = np.empty((bins.size, n))
    for i, f in enumerate(bins):
        wiped = blocks * np.exp(-2j * np.pi * f * t).astype(np.complex64)
        corr = fft.ifft(fft.fft(wiped, axis=-1) * code_spectrum, axis=-1)
        power[i] = np.sum(np.abs(corr) ** 2, axis=0)
    ib, lag = np.unravel_index(np.argmax(power), power.shape)
    exclude = int(np.ceil(fs / CHIP_RATE_HZ)) + 1
    distance = np.abs((np.arange(n) - lag + n // 2) % n - n // 2)
    second = np.max(power[ib][distance > exclude])
    code_phase = float(np.mod(-lag * code_rate_hz(bins[ib]) / fs, CHIPS))
    return Acquisition(code_phase, float(bins[ib]), float(power[ib, lag] / second))


def _epoch_indices(code_phase_chips: float, chips_per_sample: float, n_periods: int) -> np.ndarray:
    """Sample indices of the first ``n_periods + 1`` local code epochs at or after sample 0."""
    phase0 = float(np.mod(code_phase_chips, CHIPS))
    first = 0.0 if phase0 == 0.0 else float(CHIPS)
    targets = first + CHIPS * np.arange(n_periods + 1)
    index = np.ceil((targets - phase0) / chips_per_sample).astype(np.int64)
    # fix float rounding with the very expression the replica evaluates, theta(n) = phase0 + rate n
    index = np.where(phase0 + chips_per_sample * (index - 1) >= targets, index - 1, index)
    index = np.where(phase0 + chips_per_sample * index < targets, index + 1, index)
    return np.maximum(index, 0)


def correlate(samples: np.ndarray, fs: float, prn: int, code_phase_chips: float, doppler_hz: float, carrier_phase0: float,
              n_ms: int, spacing_chips: float | None = None) -> Correlations:
    """Prompt (and early/late if ``spacing_chips``) over ``n_ms`` code periods, replica state given at sample 0."""
    samples = _check_common(samples, fs)
    if n_ms < 1:
        raise ValueError(f"n_ms must be >= 1 (got {n_ms})")
    if spacing_chips is not None and not 0 < spacing_chips <= 2:
        raise ValueError(f"spacing_chips (early-late spacing) must be in (0, 2] chips (got {spacing_chips})")
    rate = float(code_rate_hz(doppler_hz)) / fs
    phase0 = float(np.mod(code_phase_chips, CHIPS))
    edges = _epoch_indices(phase0, rate, n_ms)
    if edges[-1] > samples.size:
        raise ValueError(f"{n_ms} code periods need {edges[-1]} samples from the given code phase but only {samples.size} were given")
    code = ca_code(prn).astype(np.float32)
    offsets = {"prompt": 0.0} if spacing_chips is None else {"prompt": 0.0, "early": spacing_chips / 2, "late": -spacing_chips / 2}
    out = {name: np.empty(n_ms, dtype=np.complex128) for name in offsets}
    for p0 in range(0, n_ms, CHUNK_PERIODS):
        p1 = min(p0 + CHUNK_PERIODS, n_ms)
        a, b = edges[p0], edges[p1]
        k = np.arange(a, b)
        theta = phase0 + rate * k
        wiped = samples[a:b] * np.exp(-1j * (carrier_phase0 + 2.0 * np.pi * doppler_hz / fs * k))
        starts = edges[p0:p1] - a
        counts = np.diff(edges[p0 : p1 + 1])
        for name, offset in offsets.items():
            chips = code[np.floor(theta + offset).astype(np.int64) % CHIPS]
            out[name][p0:p1] = np.add.reduceat(wiped * chips, starts) / counts
    return Correlations(out["prompt"], out.get("early"), out.get("late"), edges[:-1].copy(), np.diff(edges))
