"""Software-receiver front end for raw recordings: FFT acquisition with a detection threshold, and a 1-ms correlator.

Used on real captures (``data/real/``, read by
:func:`scintrack.signals.recording.read_recording`) and to cross-check the
synthesised recordings (:mod:`.iq`) against the correlator-level model of the
reference notes (gps-lnav-mm.md Sec. 2.2): with a replica aligned to the
truth, the prompt is ``A d e^{j dphi}`` plus complex noise of variance
``N0_eff / T``, so ``|P|^2`` over the noise variance is ``(C/N0)_eff T``.

* :func:`acquire` (one PRN) and :func:`search` (many PRNs, sharing the
  PRN-independent work) are the parallel code-phase search (Borre et al., *A
  Software-Defined GPS and Galileo Receiver*, 2007, ch. 6) of real and
  synthetic recordings, with a detection threshold for a stated false-alarm
  probability (section "Acquisition search" below);
  :func:`acquisition_table` runs it over PRNs 1-32 and returns one row per
  PRN, :func:`recording_table` does so for a recording file.
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
  ``|L| > |E|`` when ``dtau > 0`` (the notes' sign convention).  For samples
  at an intermediate frequency (real IF recordings) the carrier replica runs
  at ``IF + f_D`` and the code at the rate of ``f_D`` alone.

Acquisition search
------------------
Blocks.  The samples are cut into ``K`` blocks of ``T = n_coherent_ms`` ms
(``N = T fs`` samples; ``K = n_noncoherent``, or as many as the samples hold
when it is None).  For each Doppler bin ``f`` a block is multiplied by
``exp(-j 2 pi (IF + f) m / fs)`` (``m`` the sample index within the block;
``IF`` = 0 for complex baseband; real IF samples become complex here and
their image at ``-(2 IF + f)`` is rejected by the correlation; every
``IF + f`` must then lie more than ``1/T`` from 0 Hz, where wiped real noise
would not be circular and the threshold below would not hold).  The code
repeats every ``P = fs x 1 ms`` samples (a whole number: fs must be a
multiple of 1 kHz), so the wiped block is folded into one code period (the
sum of its ``n_coherent_ms`` periods) and correlated with one period of the
local code at the nominal 1.023 Mcps, ``c_k(l) = IFFT(FFT(y_k) conj(FFT(c)))``,
for the ``P`` lags of one code period only.  A circular correlation over all
``N`` lags holds the same peak ``n_coherent_ms`` times (exactly: the replica
is periodic in ``P``), so a second peak searched there is the first one
again and the ratio is 1; over ``P`` lags each code phase appears once.

Code Doppler.  Over the ``K`` blocks the received code drifts by ``f / f_L1``
samples per sample, ``f n_k / f_L1`` samples at block start ``n_k`` (1.3
chips over 0.5 s at 4 kHz); block ``k``'s power is shifted back by
``round(f n_k / f_L1)`` lags before the non-coherent sum
``S(l, f) = sum_k |c_k(l)|^2``, so the sum does not smear.

Statistic and threshold.  With stationary noise the correlation in a cell
without signal is circular complex Gaussian of variance ``sigma_c^2``
(``N sigma^2`` for white noise of variance ``sigma^2`` per sample), so
``|c_k|^2 / sigma_c^2`` is exponential with mean 1 and ``S / sigma_c^2`` is
``Gamma(K, 1)`` (half a ``chi^2`` with ``2K`` degrees of freedom).
``sigma_c^2`` is estimated in each Doppler bin from its own ``P`` cells: their
median divided by the median of ``Gamma(K, 1)`` (a median ignores the few
cells a satellite fills).  One estimate per bin, not one per grid, because
real front ends are not white across Doppler bins: the Pocket SDR capture
carries a comb of lines at whole kHz, synchronous with its sample clock,
that raises the floor of the bins at whole kHz by a factor 1.5-1.8 for every
PRN.  The test statistic is ``Lambda = max over cells of S / sigma_c^2``.  If
the ``N_cells = P x n_bins`` cells were independent, under noise only::

    P_fa = P(Lambda > gamma) = 1 - (1 - Q_K(gamma))^N_cells,
    Q_K(gamma) = P(Gamma(K, 1) > gamma)      (scipy.stats.gamma.sf)

so the threshold for a stated ``P_fa`` per search is
``gamma = Q_K^-1(1 - (1 - P_fa)^(1 / N_cells))`` (``scipy.stats.gamma.isf``,
with ``expm1``/``log1p`` so that a small ``P_fa`` keeps its digits).  Cells
are correlated when the lags oversample the chip (fs > 1.023 MHz) or the
Doppler step is finer than ``1/T``; the maximum of correlated cells exceeds
``gamma`` less often, so the stated ``P_fa`` is then an upper bound (it is
exact for one sample per chip and a step of ``1/T``, up to the estimation
error of ``sigma_c^2``).  The default Doppler step is ``2 / (3 T)``
(worst-case straddle loss ``sinc^2(1/3)``, 1.65 dB).

What noise-only does not cover.  The other satellites' codes and
interference synchronous with the sample clock are not noise: they put the
same power into the same cells in every block, so over ``K`` blocks they add
``K`` times their per-block power while noise adds ``K +- sqrt(K)``.  On the
Pocket SDR capture (six satellites at 40-47 dB-Hz) one coherent block of
10 or 20 ms keeps absent PRNs below ``gamma`` at ``P_fa = 1e-3``, but two or
more blocks of 2-10 ms put most absent PRNs above it.  On multi-satellite
recordings, therefore, use one long coherent block and non-coherent sums
only for files shorter than that (4 x 1 ms for the 4-ms GNSS-SDR capture).

Cross-correlation check.  A detection ``j`` is marked as the cross-correlation
of a stronger detection ``i`` (``cross_correlation_of = i``, not detected)
when their Doppler difference is within one bin step of a whole number of
kHz (where the 1-ms codes' cross-correlation lines fall) and ``Lambda_j``
does not exceed :func:`cross_correlation_threshold`: the same per-cell
false-alarm probability for cells holding noise plus a steady
cross-correlation of ``CROSS_CORRELATION_DB`` (-21.08 dB, the largest C/A
cross-correlation over PRNs 1-32 and Doppler offsets of 0 to +-10 kHz) of
``i``'s power, a noncentral ``chi^2``.

C/N0.  At the aligned cell ``E|c_k|^2 = (A N)^2 + sigma_c^2`` with
``(A N)^2 / sigma_c^2 = (C/N0) T``, so the estimate is
``C/N0 = (Lambda / K - 1) / T`` (in dB-Hz, ``10 log10``): the peak's mean
power per block less the noise mean, over the noise power, per second of
coherent integration.  It is the C/N0 the acquisition correlator sees: low
by the Doppler straddle (up to 1.65 dB), the code-phase straddle of up to
half a sample (1.2 dB at 4 MHz), data-bit edges inside coherent blocks,
front-end filtering and quantisation; NaN when ``Lambda <= K``.

``peak_ratio`` (SoftGNSS' statistic) is kept beside it: the peak over the
highest cell of the same Doppler bin farther than one chip (plus one sample)
from the peak, circularly over the ``P`` lags of one code period.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from scipy import fft, stats

from .ca_code import CHIP_RATE_HZ, CHIPS, ca_code
from .iq import L1_HZ, MS, code_rate_hz, samples_per_ms

if TYPE_CHECKING:
    import pandas as pd

#: periods processed per chunk in :func:`correlate` (bounds memory)
CHUNK_PERIODS = 50
#: default half-width of the Doppler search (Hz) and false-alarm probability per search
DEFAULT_DOPPLER_SPAN_HZ = 10e3
DEFAULT_P_FA = 1e-3
#: the largest C/A cross-correlation power relative to the peak, over PRN pairs 1-32 and Doppler offsets of 0, +-1, ..., +-10 kHz (dB)
CROSS_CORRELATION_DB = -21.08
ALL_PRNS = tuple(range(1, 33))


@dataclass(frozen=True)
class Acquisition:
    """One PRN's search result: code phase of the received code at sample 0, Doppler bin, statistic and decision.

    ``statistic`` is the normalised peak ``Lambda`` (module docstring),
    ``threshold`` the ``gamma`` for ``p_fa`` over ``n_cells`` cells and
    ``n_blocks`` non-coherent blocks, ``detected`` is ``statistic >
    threshold``; ``noise_power`` is the estimated ``sigma_c^2`` (per block and
    cell, in the samples' units squared); ``cn0_dbhz`` the C/N0 estimate.
    """

    code_phase_chips: float
    doppler_hz: float
    peak_ratio: float
    statistic: float
    threshold: float
    detected: bool
    cn0_dbhz: float
    noise_power: float
    n_blocks: int
    n_cells: int
    p_fa: float
    prn: int
    cross_correlation_of: int


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
        raise ValueError(f"samples must be a 1-D array of samples, complex or real (got shape {samples.shape})")
    if not fs > 0:
        raise ValueError(f"fs must be > 0 Hz (got {fs})")
    return samples


def local_code(prn: int, fs: float, n: int, code_phase_chips: float, doppler_hz: float = 0.0, start: int = 0) -> np.ndarray:
    """Replica chips (+-1, float32) of samples ``start .. start + n - 1``: ``c[floor(theta_0 + f_code k / fs) mod 1023]``."""
    theta = code_phase_chips + code_rate_hz(doppler_hz) / fs * np.arange(start, start + n)
    return ca_code(prn).astype(np.float32)[np.floor(theta).astype(np.int64) % CHIPS]


def doppler_bins(span_hz: float = DEFAULT_DOPPLER_SPAN_HZ, step_hz: float | None = None, n_coherent_ms: int = 1,
                 centre_hz: float = 0.0) -> np.ndarray:
    """Doppler bins ``centre + step i`` covering ``centre +- span``; ``step`` defaults to ``2 / (3 T)``, T = n_coherent_ms ms."""
    step = 2.0 / (3.0 * n_coherent_ms * MS) if step_hz is None else float(step_hz)
    if not (step > 0 and span_hz >= 0 and math.isfinite(span_hz) and math.isfinite(centre_hz)):
        raise ValueError(f"the Doppler step must be > 0 and the span >= 0 (got step {step_hz}, span {span_hz}, centre {centre_hz})")
    n = math.ceil(span_hz / step - 1e-9)
    return centre_hz + step * np.arange(-n, n + 1)


def detection_threshold(p_fa: float, n_cells: int, n_blocks: int) -> float:
    """``gamma`` with ``P(max of n_cells independent Gamma(n_blocks, 1) > gamma) = p_fa`` (module docstring)."""
    if not (0 < p_fa < 1 and n_cells >= 1 and n_blocks >= 1):
        raise ValueError(f"need 0 < p_fa < 1, n_cells >= 1 and n_blocks >= 1 (got {p_fa}, {n_cells}, {n_blocks})")
    per_cell = -math.expm1(math.log1p(-p_fa) / n_cells)
    return float(stats.gamma.isf(per_cell, n_blocks))


def false_alarm_probability(threshold: float, n_cells: int, n_blocks: int) -> float:
    """The inverse of :func:`detection_threshold`: ``1 - (1 - Q_K(threshold))^n_cells``."""
    return float(-math.expm1(n_cells * math.log1p(-stats.gamma.sf(threshold, n_blocks))))


def _blocks(samples: np.ndarray, fs: float, n_coherent_ms: int, n_noncoherent: int | None) -> np.ndarray:
    """The first ``K`` blocks of ``n_coherent_ms`` ms, shaped (K, n_coherent_ms, P)."""
    if n_coherent_ms < 1 or (n_noncoherent is not None and n_noncoherent < 1):
        raise ValueError(f"n_coherent_ms and n_noncoherent must be >= 1 (got {n_coherent_ms}, {n_noncoherent})")
    period = samples_per_ms(fs)
    n = n_coherent_ms * period
    k = samples.size // n if n_noncoherent is None else int(n_noncoherent)
    if k < 1 or samples.size < n * k:
        raise ValueError(f"acquisition needs {n * max(k, 1)} samples ({n_coherent_ms} ms x {max(k, 1)} blocks) but got {samples.size}")
    return samples[: n * k].reshape(k, n_coherent_ms, period)


def search(samples: np.ndarray, fs: float, prns: Iterable[int] = ALL_PRNS, doppler_bins_hz: Sequence[float] | None = None,
           n_coherent_ms: int = 1, n_noncoherent: int | None = None, *, doppler_span_hz: float = DEFAULT_DOPPLER_SPAN_HZ,
           doppler_step_hz: float | None = None, intermediate_frequency_hz: float = 0.0, p_fa: float = DEFAULT_P_FA) -> list[Acquisition]:
    """Search each PRN of ``prns`` over the Doppler bins and the code phases of one period (module docstring).

    ``doppler_bins_hz`` defaults to :func:`doppler_bins` ``(doppler_span_hz,
    doppler_step_hz, n_coherent_ms)``; Dopplers are relative to
    ``intermediate_frequency_hz``.  ``n_noncoherent=None`` uses every whole
    block the samples hold.  Samples are complex (baseband, or I/Q at an IF)
    or real (at the IF).  The wipe-off and the FFT of each block are done once
    per Doppler bin for all PRNs.
    """
    samples = _check_common(samples, fs)
    prns = [int(p) for p in prns]
    if not prns:
        raise ValueError("prns must name at least one PRN")
    bins = (doppler_bins(doppler_span_hz, doppler_step_hz, n_coherent_ms) if doppler_bins_hz is None
            else np.atleast_1d(np.asarray(doppler_bins_hz, dtype=float)))
    if bins.ndim != 1 or bins.size == 0 or not np.all(np.isfinite(bins)):
        raise ValueError("doppler_bins_hz must be a non-empty 1-D sequence of finite Doppler bins (Hz)")
    if not 0 < p_fa < 1:
        raise ValueError(f"p_fa must be in (0, 1) (got {p_fa})")
    if not np.iscomplexobj(samples) and not np.all(np.abs(intermediate_frequency_hz + bins) > 1.0 / (n_coherent_ms * MS)):
        # wiped real noise near 0 Hz is not circular: the Gamma(K, 1) model (and so the threshold) would not hold
        raise ValueError(f"real samples need their intermediate frequency: every IF + Doppler bin must be more than 1/T from 0 Hz "
                         f"(got intermediate_frequency_hz={intermediate_frequency_hz})")
    blocks = _blocks(samples, fs, n_coherent_ms, n_noncoherent)
    k, m, period = blocks.shape
    spectra = {prn: np.conj(fft.fft(local_code(prn, fs, period, 0.0))).astype(np.complex64) for prn in prns}
    t = np.arange(m * period).reshape(m, period) / fs
    starts = np.arange(k) * float(m * period)
    lags = np.arange(period)
    gamma_median = float(stats.gamma.median(k))
    best = {prn: (-np.inf, 0, 0, None) for prn in prns}  # normalised peak, bin index, lag, that bin's normalised row
    medians = {prn: np.empty(bins.size) for prn in prns}
    for i, f in enumerate(bins):
        mix = np.exp(-2j * np.pi * (intermediate_frequency_hz + f) * t).astype(np.complex64)
        folded = fft.fft(np.einsum("kmp,mp->kp", blocks, mix), axis=-1)
        shift = np.rint(f / L1_HZ * starts).astype(np.int64)  # code Doppler: block k's peak sits `shift` lags earlier
        gather = (lags[None, :] - shift[:, None]) % period if np.any(shift) else None
        for prn in prns:
            power = np.abs(fft.ifft(folded * spectra[prn], axis=-1)) ** 2
            if gather is not None:
                power = np.take_along_axis(power, gather, axis=-1)
            row = power.sum(axis=0, dtype=np.float64)
            noise = np.median(row) / gamma_median
            medians[prn][i] = noise
            lag = int(np.argmax(row))
            if row[lag] / noise > best[prn][0]:
                best[prn] = (float(row[lag] / noise), i, lag, row / noise)
    n_cells = period * bins.size
    gamma = detection_threshold(p_fa, n_cells, k)
    exclude = int(np.ceil(fs / CHIP_RATE_HZ)) + 1
    distance = np.abs((lags + period // 2) % period - period // 2)
    out = []
    for prn in prns:
        statistic, ib, lag, row = best[prn]
        others = row[np.roll(distance, lag) > exclude]
        second = float(np.max(others)) if others.size else 0.0
        per_block = statistic / k - 1.0
        detected = statistic > gamma
        cn0 = 10.0 * math.log10(per_block / (n_coherent_ms * MS)) if detected and 0 < per_block < math.inf else math.nan
        out.append(Acquisition(code_phase_chips=float(np.mod(-lag * code_rate_hz(bins[ib]) / fs, CHIPS)), doppler_hz=float(bins[ib]),
                               peak_ratio=statistic / second if second > 0 else math.inf, statistic=float(statistic), threshold=gamma,
                               detected=bool(detected), cn0_dbhz=cn0, noise_power=float(medians[prn][ib]), n_blocks=k,
                               n_cells=n_cells, p_fa=float(p_fa), prn=prn, cross_correlation_of=0))
    step = float(np.min(np.diff(np.unique(bins)))) if np.unique(bins).size > 1 else 0.0
    return _reject_cross_correlations(out, step, p_fa)


def cross_correlation_threshold(stronger_statistic: float, n_blocks: int, n_cells: int, p_fa: float,
                                level_db: float = CROSS_CORRELATION_DB) -> float:
    """The threshold on ``Lambda`` for cells holding noise plus a cross-correlation of a satellite whose statistic is ``stronger_statistic``.

    A cross-correlation of power ``rho e`` per block (``e = Lambda_i / K - 1``
    the stronger satellite's per-block SNR, ``rho = 10^(level_db/10)``) that
    stays the same in every block makes ``2 S / sigma_c^2`` noncentral
    ``chi^2`` with ``2K`` degrees of freedom and noncentrality ``2 K rho e``;
    the threshold is its upper quantile at the per-cell probability of
    :func:`detection_threshold`, halved (``scipy.stats.ncx2.isf``).
    """
    per_cell = -math.expm1(math.log1p(-p_fa) / n_cells)
    snr = max(stronger_statistic / n_blocks - 1.0, 0.0)
    return float(stats.ncx2.isf(per_cell, 2 * n_blocks, 2 * n_blocks * 10 ** (level_db / 10) * snr) / 2)


def _reject_cross_correlations(found: list[Acquisition], step_hz: float, p_fa: float) -> list[Acquisition]:
    """Detections that a stronger detection's cross-correlation explains, marked not detected (module docstring)."""
    kept: list[Acquisition] = []
    result = {a.prn: a for a in found}
    for a in sorted((a for a in found if a.detected), key=lambda a: -a.statistic):
        for b in kept:
            offset = a.doppler_hz - b.doppler_hz
            aligned = abs(offset - 1e3 * round(offset / 1e3)) <= step_hz + 1e-6
            if aligned and a.statistic <= cross_correlation_threshold(b.statistic, a.n_blocks, a.n_cells, p_fa):
                result[a.prn] = replace(a, detected=False, cn0_dbhz=math.nan, cross_correlation_of=b.prn)
                break
        else:
            kept.append(a)
    return [result[a.prn] for a in found]


def acquire(samples: np.ndarray, fs: float, prn: int, doppler_bins_hz: Sequence[float] | None = None, n_coherent_ms: int = 1,
            n_noncoherent: int | None = 5, **options) -> Acquisition:
    """:func:`search` for one PRN (``options``: its keyword arguments); ``n_noncoherent=None`` uses every whole block."""
    return search(samples, fs, [prn], doppler_bins_hz, n_coherent_ms, n_noncoherent, **options)[0]


#: the columns of :func:`acquisition_table` and what they hold
TABLE_COLUMNS = {
    "prn": "PRN",
    "detected": "statistic > threshold and not explained by a stronger satellite's cross-correlation",
    "doppler_hz": "Doppler bin of the peak, relative to the IF (Hz)",
    "code_phase_chips": "code phase of the received code at the first sample (chips)",
    "statistic": "normalised peak Lambda (Gamma(K, 1) per noise-only cell)",
    "threshold": "gamma for the stated false-alarm probability per search",
    "cn0_dbhz": "C/N0 estimated from the peak, (Lambda / K - 1) / T (dB-Hz); NaN when not detected",
    "peak_ratio": "peak over the highest cell of its Doppler bin beyond one chip",
    "cross_correlation_of": "PRN whose cross-correlation explains the peak (0: none)",
}


def acquisition_table(samples: np.ndarray, fs: float, prns: Iterable[int] = ALL_PRNS, **options) -> pd.DataFrame:
    """One row per PRN (columns :data:`TABLE_COLUMNS`); ``options`` go to :func:`search`; the search settings are in ``attrs``."""
    import pandas as pd

    found = search(samples, fs, prns, **options)
    df = pd.DataFrame([{key: getattr(a, key) for key in TABLE_COLUMNS} for a in found], columns=list(TABLE_COLUMNS))
    df.attrs.update({"p_fa_per_search": found[0].p_fa, "n_blocks": found[0].n_blocks, "n_cells": found[0].n_cells,
                     "n_coherent_ms": int(options.get("n_coherent_ms", 1)), "sample_rate_hz": float(fs),
                     "intermediate_frequency_hz": float(options.get("intermediate_frequency_hz", 0.0)), "columns": dict(TABLE_COLUMNS)})
    return df


def recording_table(path, prns: Iterable[int] = ALL_PRNS, **options) -> pd.DataFrame:
    """:func:`acquisition_table` of a recording file, read by :func:`scintrack.signals.recording.read_recording` (its fs and IF)."""
    from ..recording import read_recording

    samples, meta = read_recording(path)
    options.setdefault("intermediate_frequency_hz", float(meta["intermediate_frequency_hz"]))
    df = acquisition_table(samples, float(meta["sample_rate_hz"]), prns, **options)
    df.attrs["recording"] = str(path)
    return df


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
              n_ms: int, spacing_chips: float | None = None, *, intermediate_frequency_hz: float = 0.0) -> Correlations:
    """Prompt (and early/late if ``spacing_chips``) over ``n_ms`` code periods, replica state given at sample 0.

    The carrier replica runs at ``intermediate_frequency_hz + doppler_hz`` (real IF samples work as they are).
    """
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
        wiped = samples[a:b] * np.exp(-1j * (carrier_phase0 + 2.0 * np.pi * (intermediate_frequency_hz + doppler_hz) / fs * k))
        starts = edges[p0:p1] - a
        counts = np.diff(edges[p0 : p1 + 1])
        for name, offset in offsets.items():
            chips = code[np.floor(theta + offset).astype(np.int64) % CHIPS]
            out[name][p0:p1] = np.add.reduceat(wiped * chips, starts) / counts
    return Correlations(out["prompt"], out.get("early"), out.get("late"), edges[:-1].copy(), np.diff(edges))
