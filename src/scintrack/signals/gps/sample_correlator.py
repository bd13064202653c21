"""Sample-level early/prompt/late correlator with code and carrier NCOs, one local code period per call.

The closed-loop counterpart of :func:`.acquisition.correlate` (same replica,
same conventions, same normalisation): a tracking loop calls
:meth:`SampleCorrelator.correlate` once per code period and sets, for each
period, the code rate and the carrier frequency and phase that its last
update gave; the correlator carries the NCO states from one period to the
next.

* Code NCO.  The replica code phase (chips) at sample ``n`` of a period that
  starts at sample ``a`` is ``theta(n) = theta_a + r (n - a)``, ``r =
  f_code / fs`` chips per sample, and the chip is ``c[floor(theta) mod 1023]``
  (nearest-chip sampling, as :mod:`.iq` synthesises and :mod:`.acquisition`
  correlates).  A period runs from one local code epoch to the next: it ends
  at the first sample where ``theta`` reaches 1023, and the next period starts
  there with ``theta - 1023`` (in ``[0, r)``).  LNAV bit edges fall on code
  epochs, so with the replica aligned no prompt straddles a bit edge.  The
  first period starts at the first code epoch at or after sample 0 of the
  received code phase given (an acquisition's ``code_phase_chips``).
* Carrier NCO.  The replica is ``exp(j (2 pi f_IF t_n + psi(t_n)))``, ``t_n =
  n / fs``, with ``psi(t) = psi_ref + 2 pi f (t - t_ref)`` over the period:
  the loop gives the frequency ``f`` (Hz, Doppler) and either the phase
  ``psi_ref`` at a time ``t_ref`` of its choosing (a PLL's or Kalman filter's
  phase estimate for the epoch) or nothing, and then the phase continues from
  where the previous period ended (a frequency-only NCO).
* Early and late replicas are the code advanced and delayed by
  ``spacing/2`` chips, so with ``dtau`` = true minus replica code delay,
  ``|L| > |E|`` when ``dtau > 0`` (the convention of
  :mod:`scintrack.navigation.dll`).
* Outputs are sample means (sum / number of samples), so an aligned prompt's
  signal part is the signal amplitude and its complex noise variance is
  ``N0 / T`` for white noise of density N0 (``T`` = samples / fs).

Each period is one vectorised numpy pass over its ~``fs`` x 1 ms samples
(4000 at 4 MS/s): three gathers from the code and one complex exponential.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np

from .ca_code import CHIPS, ca_code


@dataclass(frozen=True)
class PeriodCorrelation:
    """One code period's correlator outputs and where it lies in the samples.

    ``start``/``n_samples``: first sample and length of the period;
    ``code_phase_chips``: replica code phase at ``start`` (in ``[0, r)``, just past the epoch);
    ``carrier_phase_rad``: replica carrier phase ``psi`` (without the IF term) at ``start``.
    """

    early: complex
    prompt: complex
    late: complex
    start: int
    n_samples: int
    code_phase_chips: float
    code_rate_hz: float
    carrier_phase_rad: float
    carrier_freq_hz: float

    @property
    def end(self) -> int:
        """One past the last sample of the period (the start of the next)."""
        return self.start + self.n_samples


def first_epoch(code_phase_chips: float, code_rate_hz: float, fs: float) -> tuple[int, float]:
    """Sample index of the first code epoch at or after sample 0, and the code phase there (in ``[0, r)``)."""
    phase0 = float(np.mod(code_phase_chips, CHIPS))
    if phase0 == 0.0:
        return 0, 0.0
    r = code_rate_hz / fs
    n = _samples_to(CHIPS - phase0, r)
    return n, phase0 + r * n - CHIPS


def _samples_to(distance_chips: float, r: float) -> int:
    """Smallest ``n >= 1`` with ``r n >= distance_chips`` (as the replica evaluates it)."""
    n = max(int(np.ceil(distance_chips / r)), 1)
    while n > 1 and r * (n - 1) >= distance_chips:  # float rounding of the division
        n -= 1
    while r * n < distance_chips:
        n += 1
    return n


class SampleCorrelator:
    """E/P/L correlation of raw complex baseband samples against a C/A replica, one code period per call.

    ``samples``: 1-D complex (or real IF) samples at ``fs``; ``code_phase_chips``: phase of the
    received code at sample 0 (acquisition); ``code_rate_hz`` (chips/s): rate used to find the
    first code epoch; ``spacing_chips``: early-late spacing; ``intermediate_frequency_hz``: where
    the L1 carrier lies in the samples (0 for complex baseband).
    """

    def __init__(self, samples: np.ndarray, fs: float, prn: int, code_phase_chips: float, code_rate_hz: float, *,
                 spacing_chips: float = 1.0, intermediate_frequency_hz: float = 0.0):
        samples = np.asarray(samples)
        if samples.ndim != 1:
            raise ValueError(f"samples must be a 1-D array (got shape {samples.shape})")
        if not fs > 0:
            raise ValueError(f"fs must be > 0 Hz (got {fs})")
        if not 0 < spacing_chips < 2:
            raise ValueError(f"spacing_chips (early-late spacing) must be in (0, 2) chips (got {spacing_chips})")
        self.samples, self.fs, self.prn = samples, float(fs), int(prn)
        self.spacing = float(spacing_chips)
        self.f_if = float(intermediate_frequency_hz)
        self.code = ca_code(prn).astype(np.float32)
        self.start, self.code_phase = first_epoch(code_phase_chips, code_rate_hz, self.fs)
        self.carrier_phase = 0.0  # psi at sample self.start

    def clone(self) -> SampleCorrelator:
        """An independent correlator in the same NCO state (shares the read-only samples)."""
        return copy.copy(self)

    def period_samples(self, code_rate_hz: float) -> int:
        """Length in samples of the next period at ``code_rate_hz``."""
        if not code_rate_hz > 0:
            raise ValueError(f"code_rate_hz must be > 0 chips/s (got {code_rate_hz})")
        return _samples_to(CHIPS - self.code_phase, code_rate_hz / self.fs)

    def fits(self, code_rate_hz: float) -> bool:
        """Whether the next period at ``code_rate_hz`` ends within the samples."""
        return self.start + self.period_samples(code_rate_hz) <= self.samples.size

    def time(self, sample: float) -> float:
        """Time (s) of a (fractional) sample index."""
        return sample / self.fs

    def correlate(self, code_rate_hz: float, carrier_freq_hz: float, carrier_phase_rad: float | None = None,
                  phase_time_s: float | None = None) -> PeriodCorrelation:
        """Correlate the next code period and advance both NCOs to its end.

        ``carrier_phase_rad`` is the replica phase ``psi`` at ``phase_time_s`` (default: the
        period's mean sample time); None continues the carrier NCO from the previous period.
        """
        n = self.period_samples(code_rate_hz)
        a, b = self.start, self.start + n
        if b > self.samples.size:
            raise ValueError(f"the code period from sample {a} needs {n} samples but only {self.samples.size - a} are left")
        r = code_rate_hz / self.fs
        k = np.arange(n, dtype=np.float64)
        theta = self.code_phase + r * k
        w = 2.0 * np.pi * carrier_freq_hz / self.fs  # rad per sample
        if carrier_phase_rad is None:
            psi_a = self.carrier_phase
        else:
            t_ref = (a + 0.5 * (n - 1)) / self.fs if phase_time_s is None else float(phase_time_s)
            psi_a = float(carrier_phase_rad) + 2.0 * np.pi * carrier_freq_hz * (a / self.fs - t_ref)
        phase = psi_a + w * k
        if self.f_if != 0.0:
            phase = phase + 2.0 * np.pi * self.f_if / self.fs * (a + k)
        wiped = self.samples[a:b] * np.exp(-1j * phase)
        out = []
        for offset in (0.5 * self.spacing, 0.0, -0.5 * self.spacing):
            chips = self.code[np.floor(theta + offset).astype(np.int64) % CHIPS]
            out.append(complex(np.dot(wiped, chips) / n))
        result = PeriodCorrelation(out[0], out[1], out[2], a, n, self.code_phase, float(code_rate_hz), psi_a, float(carrier_freq_hz))
        self.start = b
        self.code_phase = self.code_phase + r * n - CHIPS
        self.carrier_phase = psi_a + w * n
        return result
