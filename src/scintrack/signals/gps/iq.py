"""SKYDEL-like GPS L1 C/A IQ recordings: synthesis, int16 file + JSON sidecar writer and reader.

The paper (Zhao, Khanafseh & Pervan, Sec. IV) records the SKYDEL output as
complex baseband I/Q at 12.5 MS/s, intermediate frequency 0, and processes
it with a software receiver; an 8-MHz AWGN jammer is switched on two minutes
into the scenario.  This module builds such a recording from per-1-ms truth.

Signal model (reference notes gps-lnav-mm.md Sec. 2.2) at sample times
``t_n = n / fs``::

    x(t) = sum_i A_i c_i(theta_i(t)) d_i(t) exp(j phi_i(t)) + w(t) + j(t)

* ``A_i^2 = C_i`` is satellite i's carrier power and ``C_i / N0`` its C/N0.
* Within ms k (``t = k T + u``, ``T = 1 ms``) the code phase (chips of the
  received code) is ``theta = theta_k + f_code,k u`` with the carrier-aided
  code rate ``f_code = 1.023e6 (1 + f_D / 1575.42e6)`` and the carrier phase
  is ``phi = phi_k + 2 pi f_D,k u`` (linear interpolation from the values at
  the start of each ms).  The chip is ``c[floor(theta) mod 1023]``: the chip
  waveform is sampled at the sample instants (nearest-chip sampling).
* ``d_i`` is the data bit in effect at the start of ms k; a change to the next
  ms's bit happens at the code epoch inside ms k (where ``theta`` reaches
  1023), because LNAV bit edges coincide with C/A code epochs (IS-GPS-200
  Sec. 3.3.4; reference notes Sec. 1.1).  Per-ms truth therefore never
  places a bit edge mid-code.
* ``w`` is thermal noise, complex white Gaussian, variance ``N0 fs`` per
  sample (``N0 fs / 2`` per component).
* ``j`` is the jammer (:class:`Jammer`): band-limited complex Gaussian noise
  of power ``J = (J/S) S`` where S is the received carrier power of *one*
  satellite (the paper's J/S), at the reference C/N0 ``S / N0``.

Choices the spec leaves open, and why:

* Front end = the 12.5-MHz complex sampling itself, no filter.  An ideal
  +-6.25 MHz filter would keep 98.3 % of the C/A power and round the
  correlation triangle slightly (-0.07 dB).  Here the chips are point-sampled
  instead, so the 1.7 % beyond +-6.25 MHz aliases back into the band rather
  than being lost: every signal sample is exactly ``+-A``, a replica sampled
  the same way (:mod:`.acquisition`) recovers all of C, and because
  ``fs / R_c = 12.22`` is not an integer, the triangle over a code period
  stays sharp (measured R(d) = 1 - 1.001 d, the Gold code's 512 chip
  transitions per 1023 chips).  The jammer's spectral separation with the aliased replica
  spectrum is 0.04 dB above :func:`jamming.spectral_separation` (8 MHz,
  unlimited front end), which is what we quote; both differences are far
  below the 1-dB level the cross-checks work at.
* Jammer filter: a linear-phase (type-I, odd length) FIR low-pass from
  ``scipy.signal.firwin`` with a Kaiser window sized by ``kaiserord`` for
  60-dB stopband and a 0.4-MHz transition centred on ``B/2`` (115 taps at
  12.5 MS/s; passband ripple ~0.01 dB), modulated to ``offset_hz``.  With
  the cutoff (-6 dB) at ``B/2`` the equivalent noise bandwidth would be 7.91
  MHz for B = 8 MHz (the transition loses more power than a brick wall), so
  the cutoff is moved out until the ENBW equals ``B``
  (:func:`equivalent_noise_bandwidth`), keeping the jammer's density J/B, the
  flat-spectrum level that :func:`jamming.spectral_separation` assumes.
  The taps are scaled to unit energy and driven with complex white noise of
  variance J, so the jammer's expected power is exactly J.  The filter runs
  continuously over chunks (overlap with the previous ``ntaps - 1`` white
  samples); ``ntaps - 1`` warm-up samples are drawn at the onset, so the
  jammer is stationary from its first sample.  It switches on abruptly at
  ``onset_s`` (the paper's "abruptly subjected to RFI").
* ``n0`` defaults to ``1/fs`` (unit thermal variance per complex sample); only
  ratios C/N0 and J/S matter.  The satellites' C are set relative to N0.
* Randomness: thermal noise and jammer come from two independent streams,
  :func:`scintrack.seeding.rng_for` ``(seed, "gps-iq/thermal"|"gps-iq/jammer", 0)``,
  so a jammed segment equals the clean segment of the same seed plus the
  jammer, sample for sample (before quantisation).
* Work is done in 10-ms chunks (``CHUNK_MS``); the draws are sequential, so
  signal and thermal noise do not depend on the chunking (the jammer's FFT
  convolution only to float32 rounding).  ``synthesise`` still returns the
  whole segment: a 4-min recording (3e9 samples) would need a streaming
  writer with a fixed scale.
* File format: int16 interleaved I/Q, little-endian, ``round(scale * x)``.
  By default ``scale`` maps the largest |I| or |Q| of the segment to 0.9 of
  32767 (no clipping by construction; the segment is in memory anyway).  A
  fixed ``scale`` may be passed instead (e.g. from the expected total power
  at k sigma, for streaming); values beyond +-32767 are then clipped and
  counted.  The writer reports the quantisation SNR.  Data and sidecar are
  each written to a temporary file and moved into place with
  ``os.replace``; the sidecar (``<data>.json``) carries the sha256 of the
  data file, which :func:`read_recording` checks.  The writer also fills the
  fields every recording's sidecar has (:mod:`scintrack.signals.recording`):
  ``iq_sign`` = +1, ``start_time`` (GPS time of the first sample, from
  ``gps_week`` and ``gps_seconds_of_week``, ``time_scale`` "GPS") and
  ``source``; the one reader of recordings, ours and real captures alike, is
  :func:`scintrack.signals.recording.read_recording`, re-exported here.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import signal

from ...atomic import atomic_bytes
from ...seeding import rng_for
from ..recording import IQFormatError, read_recording, sidecar_path  # noqa: F401 (the reader of every recording, re-exported)
from .ca_code import CHIP_RATE_HZ, CHIPS, ca_code
from .jamming import effective_cn0_dbhz, spectral_separation

L1_HZ = 1575.42e6
DEFAULT_FS_HZ = 12.5e6
MS = 1e-3
CHUNK_MS = 10
FORMAT = "int16 interleaved IQ little-endian"
FULL_SCALE = 32767
DEFAULT_PEAK_FRACTION = 0.9
DATA_SUFFIXES = (".bin", ".dat")
MAX_DOPPLER_HZ = 100e3
JAMMER_TRANSITION_HZ = 0.4e6
JAMMER_STOPBAND_DB = 60.0
#: keys the caller's sidecar must hold (see :func:`make_sidecar`)
SIDECAR_KEYS = ("sample_rate_hz", "centre_frequency_hz", "intermediate_frequency_hz", "gps_week", "gps_seconds_of_week",
                "duration_s", "satellites", "jammer", "seed")
#: keys the writer fills in
WRITER_KEYS = ("format", "scale", "scale_rule", "n_samples", "data_file", "sha256", "clipped_values", "quantisation_snr_db",
               "iq_sign", "start_time", "time_scale")
SOURCE = "synthetic: scintrack.signals.gps.iq.synthesise"
GPS_EPOCH = dt.datetime(1980, 1, 6)


def code_rate_hz(doppler_hz: np.ndarray | float) -> np.ndarray | float:
    """Carrier-aided C/A code rate ``1.023e6 (1 + f_D / f_L1)`` (chips/s)."""
    return CHIP_RATE_HZ * (1.0 + np.asarray(doppler_hz, dtype=float) / L1_HZ)


def _per_ms(name: str, values, n: int | None = None) -> np.ndarray:
    arr = np.asarray(values, dtype=float)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"SvSignal.{name} must be a non-empty 1-D array with one value per ms (got shape {arr.shape})")
    if n is not None and arr.size != n:
        raise ValueError(f"SvSignal.{name} has {arr.size} values but code_phase_chips has {n}; give one value per ms for each")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"SvSignal.{name} contains non-finite values")
    return arr


@dataclass(frozen=True, eq=False)
class SvSignal:
    """One satellite's received signal, as values at the start of each 1-ms interval of the segment.

    ``code_phase_chips``: phase of the received code in chips, [0, 1023);
    ``carrier_phase_rad``: carrier phase; ``doppler_hz``: carrier Doppler, also
    used for the code rate; ``data_bits``: +-1, the data bit in effect.
    """

    prn: int
    cn0_dbhz: float
    code_phase_chips: np.ndarray
    carrier_phase_rad: np.ndarray
    doppler_hz: np.ndarray
    data_bits: np.ndarray

    def __post_init__(self):
        ca_code(self.prn)  # ValueError for a PRN without a C/A code
        if not np.isfinite(self.cn0_dbhz):
            raise ValueError(f"SvSignal.cn0_dbhz must be finite (got {self.cn0_dbhz})")
        code = _per_ms("code_phase_chips", self.code_phase_chips)
        if np.any((code < 0) | (code >= CHIPS)):
            raise ValueError("SvSignal.code_phase_chips must lie in [0, 1023); wrap them with np.mod(phase, 1023)")
        doppler = _per_ms("doppler_hz", self.doppler_hz, code.size)
        if np.any(np.abs(doppler) > MAX_DOPPLER_HZ):
            raise ValueError(f"SvSignal.doppler_hz must stay within +-{MAX_DOPPLER_HZ:g} Hz (one code epoch per ms at most)")
        bits = _per_ms("data_bits", self.data_bits, code.size)
        if not np.all(np.abs(bits) == 1):
            raise ValueError("SvSignal.data_bits must be +1 or -1 (map bit 0 -> +1, bit 1 -> -1)")
        object.__setattr__(self, "code_phase_chips", code)
        object.__setattr__(self, "carrier_phase_rad", _per_ms("carrier_phase_rad", self.carrier_phase_rad, code.size))
        object.__setattr__(self, "doppler_hz", doppler)
        object.__setattr__(self, "data_bits", bits)

    @property
    def n_ms(self) -> int:
        return int(self.code_phase_chips.size)

    @classmethod
    def constant_doppler(cls, prn: int, cn0_dbhz: float, n_ms: int, doppler_hz: float, code_phase0_chips: float,
                         carrier_phase0_rad: float = 0.0, nav_bits=None, code_periods_into_bit: int = 0) -> SvSignal:
        """Truth for a constant Doppler; ``nav_bits`` (+-1, 50 bps) change every 20 code periods.

        ``code_periods_into_bit`` (0-19) is how many whole code periods of the
        first bit have passed at t = 0; the code period in progress at t = 0
        is number 0.  ``nav_bits=None`` means all bits +1.
        """
        if not 0 <= code_periods_into_bit < 20:
            raise ValueError(f"code_periods_into_bit must be in 0..19 (got {code_periods_into_bit})")
        t = np.arange(int(n_ms)) * MS
        unwrapped = code_phase0_chips + code_rate_hz(doppler_hz) * t
        period = np.floor(unwrapped / CHIPS).astype(np.int64)
        if nav_bits is None:
            bits = np.ones(int(n_ms))
        else:
            nav = np.asarray(nav_bits, dtype=float)
            index = (period + code_periods_into_bit) // 20
            if index[-1] >= nav.size:
                raise ValueError(f"nav_bits has {nav.size} bits but {index[-1] + 1} are needed for {n_ms} ms")
            bits = nav[index]
        phase = np.angle(np.exp(1j * (carrier_phase0_rad + 2.0 * np.pi * doppler_hz * t)))
        return cls(prn, cn0_dbhz, np.mod(unwrapped, CHIPS), phase, np.full(int(n_ms), float(doppler_hz)), bits)


@dataclass(frozen=True)
class Jammer:
    """Band-limited AWGN jammer of power ``J = 10^(js_db/10) S`` (S: one satellite's received carrier power).

    ``reference_cn0_dbhz`` is S/N0; None takes the common C/N0 of the
    satellites (they must then all have the same one).  The jammer is flat
    over ``bandwidth_hz`` centred ``offset_hz`` from L1 and is on from ``onset_s``.
    """

    js_db: float
    bandwidth_hz: float = 8e6
    offset_hz: float = 0.0
    onset_s: float = 0.0
    reference_cn0_dbhz: float | None = None

    def __post_init__(self):
        if not np.isfinite(self.js_db):
            raise ValueError(f"Jammer.js_db must be finite (got {self.js_db}); use jammer=None for no jammer")
        if not self.bandwidth_hz > 0:
            raise ValueError(f"Jammer.bandwidth_hz must be > 0 (got {self.bandwidth_hz})")
        if not self.onset_s >= 0:
            raise ValueError(f"Jammer.onset_s must be >= 0 s (got {self.onset_s})")

    def reference_cn0(self, svs) -> float:
        """S/N0 in dB-Hz: ``reference_cn0_dbhz`` or the satellites' common C/N0."""
        if self.reference_cn0_dbhz is not None:
            return float(self.reference_cn0_dbhz)
        levels = {float(sv.cn0_dbhz) for sv in svs}
        if len(levels) != 1:
            raise ValueError(f"Jammer.reference_cn0_dbhz is needed: the satellites' C/N0 differ ({sorted(levels)}), so S is ambiguous")
        return levels.pop()

    def power(self, n0: float, svs) -> float:
        """J in the units of ``n0 * Hz``."""
        return 10.0 ** (self.js_db / 10.0) * n0 * 10.0 ** (self.reference_cn0(svs) / 10.0)

    def kappa(self) -> float:
        """Spectral separation coefficient with C/A (1/Hz), :func:`jamming.spectral_separation`."""
        return spectral_separation(self.bandwidth_hz, self.offset_hz)


def jammer_taps(bandwidth_hz: float, offset_hz: float, fs: float) -> np.ndarray:
    """Unit-energy linear-phase FIR whose passband is ``bandwidth_hz`` wide around ``offset_hz`` (complex if offset)."""
    half = bandwidth_hz / 2.0
    if abs(offset_hz) + half + JAMMER_TRANSITION_HZ / 2.0 > fs / 2.0:
        raise ValueError(f"jammer band {offset_hz:g} +- {half:g} Hz (plus {JAMMER_TRANSITION_HZ / 2:g} Hz transition) "
                         f"does not fit in the sampled band +-{fs / 2:g} Hz; narrow it or raise fs")
    numtaps, beta = signal.kaiserord(JAMMER_STOPBAND_DB, JAMMER_TRANSITION_HZ / (fs / 2.0))
    numtaps |= 1  # odd length: type-I linear phase
    cutoff = half
    for _ in range(3):  # ENBW grows 2 Hz per Hz of cutoff: move the cutoff until ENBW = bandwidth
        taps = signal.firwin(numtaps, cutoff, window=("kaiser", beta), fs=fs)
        cutoff += (bandwidth_hz - equivalent_noise_bandwidth(taps, fs)) / 2.0
    if offset_hz != 0.0:
        taps = taps * np.exp(2j * np.pi * offset_hz * np.arange(numtaps) / fs)
    return taps / np.sqrt(np.sum(np.abs(taps) ** 2))


def equivalent_noise_bandwidth(taps: np.ndarray, fs: float, centre_hz: float = 0.0) -> float:
    """``integral |H(f)|^2 df / |H(centre)|^2 = fs sum|h|^2 / |H(centre)|^2`` (Hz)."""
    h0 = np.sum(taps * np.exp(-2j * np.pi * centre_hz * np.arange(len(taps)) / fs))
    return float(fs * np.sum(np.abs(taps) ** 2) / np.abs(h0) ** 2)


def _white(rng: np.random.Generator, n: int, variance: float) -> np.ndarray:
    """Complex white Gaussian noise, ``variance`` per complex sample, complex64."""
    z = rng.standard_normal(2 * n, dtype=np.float32).view(np.complex64)
    return z * np.float32(np.sqrt(variance / 2.0))


class _JammerSource:
    """Continuous band-limited noise, produced chunk by chunk (overlap-save of the white input)."""

    def __init__(self, taps: np.ndarray, power: float, rng: np.random.Generator):
        self.taps = taps.astype(np.complex64 if np.iscomplexobj(taps) else np.float32)
        self.power, self.rng = power, rng
        self.history = _white(rng, len(taps) - 1, power)

    def next(self, n: int) -> np.ndarray:
        ext = np.concatenate([self.history, _white(self.rng, n, self.power)])
        self.history = ext[len(ext) - (len(self.taps) - 1):]
        return signal.oaconvolve(ext, self.taps, mode="valid").astype(np.complex64, copy=False)


def samples_per_ms(fs: float) -> int:
    """Whole samples in one millisecond at ``fs`` (a multiple of 1 kHz, else ``ValueError``)."""
    per_ms = fs * MS
    if not fs > 0 or abs(per_ms - round(per_ms)) > 1e-9 * per_ms:
        raise ValueError(f"fs must be a positive multiple of 1 kHz so that each ms holds whole samples (got {fs})")
    return int(round(per_ms))


def _sv_chunk(sv: SvSignal, k0: int, k1: int, u: np.ndarray, amplitude: float, code: np.ndarray) -> np.ndarray:
    """The satellite's samples over ms k0..k1-1, complex64 of shape (k1 - k0, samples per ms).

    Each ms gets a 2046-entry table: the code times the bit in effect at the
    start of the ms, then the code times the next ms's bit (after the epoch,
    where ``theta`` passes 1023); one gather applies code, wrap and bit edge.
    """
    ms = np.arange(k0, k1)
    theta = sv.code_phase_chips[k0:k1, None] + code_rate_hz(sv.doppler_hz[k0:k1])[:, None] * u
    following = sv.data_bits[np.minimum(ms + 1, sv.n_ms - 1)]
    table = np.concatenate([sv.data_bits[k0:k1, None] * code, following[:, None] * code], axis=1).astype(np.float32)
    index = theta.astype(np.int32) + (2 * CHIPS) * np.arange(k1 - k0, dtype=np.int32)[:, None]  # theta >= 0: truncation = floor
    chips = table.ravel()[index]
    phase = (np.mod(sv.carrier_phase_rad[k0:k1], 2.0 * np.pi)[:, None] + 2.0 * np.pi * sv.doppler_hz[k0:k1, None] * u).astype(np.float32)
    out = np.empty(theta.shape, dtype=np.complex64)
    scaled = np.float32(amplitude) * chips
    out.real = scaled * np.cos(phase)
    out.imag = scaled * np.sin(phase)
    return out


def synthesise(svs, fs: float = DEFAULT_FS_HZ, *, duration_s: float, seed: int, n0: float | None = None,
               jammer: Jammer | None = None) -> np.ndarray:
    """Complex baseband samples (complex64) of satellites + thermal noise + jammer over ``duration_s``."""
    svs = list(svs)
    per_ms = samples_per_ms(fs)
    n = int(round(duration_s * fs))
    if n <= 0:
        raise ValueError(f"duration_s must give at least one sample (got {duration_s})")
    n_ms = -(-n // per_ms)
    for sv in svs:
        if sv.n_ms < n_ms:
            raise ValueError(f"PRN {sv.prn} truth covers {sv.n_ms} ms but duration_s={duration_s} needs {n_ms}")
    if len({sv.prn for sv in svs}) != len(svs):
        raise ValueError("each PRN may appear once in svs")
    n0 = 1.0 / fs if n0 is None else float(n0)
    if not n0 > 0:
        raise ValueError(f"n0 must be > 0 (got {n0})")
    thermal_rng = rng_for(seed, "gps-iq/thermal", 0)
    jam, jam_args, n_onset = None, None, n
    if jammer is not None:
        n_onset = min(n, math.ceil(jammer.onset_s * fs - 1e-9))
        jam_args = (jammer_taps(jammer.bandwidth_hz, jammer.offset_hz, fs), jammer.power(n0, svs))
    u = np.arange(per_ms) / fs
    codes = {sv.prn: ca_code(sv.prn) for sv in svs}
    amps = {sv.prn: np.sqrt(n0 * 10.0 ** (sv.cn0_dbhz / 10.0)) for sv in svs}
    out = np.empty(n, dtype=np.complex64)
    for k0 in range(0, n_ms, CHUNK_MS):
        k1 = min(k0 + CHUNK_MS, n_ms)
        a, b = k0 * per_ms, min(k1 * per_ms, n)
        block = _white(thermal_rng, b - a, n0 * fs)
        for sv in svs:
            block += _sv_chunk(sv, k0, k1, u, amps[sv.prn], codes[sv.prn]).ravel()[: b - a]
        if b > n_onset:
            if jam is None:
                jam = _JammerSource(*jam_args, rng_for(seed, "gps-iq/jammer", 0))
            start = max(a, n_onset)
            block[start - a:] += jam.next(b - start)
        out[a:b] = block
    return out


def make_sidecar(svs, *, fs: float, duration_s: float, seed: int, gps_week: int, gps_seconds_of_week: float,
                 jammer: Jammer | None = None, n0: float | None = None) -> dict:
    """The caller's part of a recording's sidecar (the writer adds format, scale, size and sha256)."""
    svs = list(svs)
    n0 = 1.0 / fs if n0 is None else float(n0)
    sats = [{"prn": int(sv.prn), "cn0_dbhz": float(sv.cn0_dbhz)} for sv in svs]
    jam = None
    if jammer is not None:
        kappa = jammer.kappa()
        ref = jammer.reference_cn0(svs)
        taps = jammer_taps(jammer.bandwidth_hz, jammer.offset_hz, fs)
        for entry in sats:
            js_this = jammer.js_db + ref - entry["cn0_dbhz"]
            entry["effective_cn0_dbhz_after_onset"] = float(effective_cn0_dbhz(entry["cn0_dbhz"], js_this, kappa))
        jam = {"js_db": float(jammer.js_db), "s_reference_cn0_dbhz": ref,
               "s_meaning": "S = received carrier power of one satellite at s_reference_cn0_dbhz (the paper's J/S)",
               "bandwidth_hz": float(jammer.bandwidth_hz), "offset_hz": float(jammer.offset_hz), "onset_s": float(jammer.onset_s),
               "kappa_per_hz": kappa, "power_over_thermal_db": float(10 * np.log10(jammer.power(n0, svs) / (n0 * fs))),
               "filter": {"design": "scipy.signal.firwin, Kaiser window (kaiserord)", "numtaps": len(taps),
                          "stopband_db": JAMMER_STOPBAND_DB, "transition_hz": JAMMER_TRANSITION_HZ,
                          "equivalent_noise_bandwidth_hz": equivalent_noise_bandwidth(taps, fs, jammer.offset_hz)}}
    return {"sample_rate_hz": float(fs), "centre_frequency_hz": L1_HZ, "intermediate_frequency_hz": 0.0,
            "gps_week": int(gps_week), "gps_seconds_of_week": float(gps_seconds_of_week), "duration_s": float(duration_s),
            "satellites": sats, "jammer": jam, "seed": int(seed), "thermal_noise_variance_per_sample": float(n0 * fs),
            "front_end": "none: 12.5 MS/s complex point sampling of the chips (aliased C/A tails kept)"}


def gps_time_iso(gps_week: int, gps_seconds_of_week: float) -> str:
    """GPS time ``gps_week``, ``gps_seconds_of_week`` as ISO 8601 (GPS time scale, no leap seconds), e.g. ``2015-10-07T00:00:00``."""
    return (GPS_EPOCH + dt.timedelta(weeks=int(gps_week), seconds=float(gps_seconds_of_week))).isoformat()


def _atomic_write(path: Path, payload: bytes) -> None:
    atomic_bytes(path, payload, fsync=True)


def quantise(samples: np.ndarray, scale: float) -> tuple[np.ndarray, int]:
    """``round(scale * [I, Q])`` as little-endian int16 interleaved, and the count of clipped values."""
    iq = np.asarray(samples, dtype=np.complex64).view(np.float32) * np.float32(scale)
    q = np.rint(iq)
    clipped = int(np.count_nonzero(np.abs(q) > FULL_SCALE))
    return np.clip(q, -FULL_SCALE, FULL_SCALE).astype("<i2"), clipped


def write_recording(path: str | os.PathLike, samples: np.ndarray, sidecar: dict, *, scale: float | None = None,
                    peak_fraction: float = DEFAULT_PEAK_FRACTION) -> dict:
    """Write int16 I/Q (``.bin``/``.dat``) and ``<path>.json``; returns the full sidecar written."""
    path = Path(path)
    if path.suffix not in DATA_SUFFIXES:
        raise ValueError(f"recording path {path} must end in one of {DATA_SUFFIXES}")
    missing = [key for key in SIDECAR_KEYS if key not in sidecar]
    if missing:
        raise ValueError(f"sidecar lacks {missing}; build it with iq.make_sidecar")
    samples = np.asarray(samples)
    if samples.ndim != 1 or samples.size == 0 or not np.iscomplexobj(samples):
        raise ValueError("samples must be a non-empty 1-D complex array")
    if abs(samples.size - sidecar["duration_s"] * sidecar["sample_rate_hz"]) > 0.5:
        raise ValueError(f"sidecar duration_s * sample_rate_hz != {samples.size} samples")
    if scale is None:
        if not 0 < peak_fraction <= 1:
            raise ValueError(f"peak_fraction must be in (0, 1] (got {peak_fraction})")
        peak = float(np.max(np.abs(samples.view(np.float32 if samples.dtype == np.complex64 else np.float64))))
        if peak == 0:
            raise ValueError("samples are all zero: no peak to scale to; pass scale explicitly")
        scale = peak_fraction * FULL_SCALE / peak
        rule = f"largest |I| or |Q| of the segment -> {peak_fraction} x {FULL_SCALE}"
    else:
        if not scale > 0:
            raise ValueError(f"scale must be > 0 (got {scale})")
        rule = "fixed scale given by the caller"
    data, clipped = quantise(samples, scale)
    payload = data.tobytes()
    err = data.astype(np.float64) / scale - samples.astype(np.complex128).view(np.float64)
    qsnr = 10 * np.log10(np.mean(np.abs(samples.astype(np.complex128)) ** 2) / (2 * np.mean(err**2)))
    full = {k: v for k, v in sidecar.items() if k not in WRITER_KEYS}
    full.update({"format": FORMAT, "scale": float(scale), "scale_rule": rule, "n_samples": int(samples.size),
                 "data_file": path.name, "sha256": hashlib.sha256(payload).hexdigest(), "clipped_values": clipped,
                 "quantisation_snr_db": float(qsnr), "iq_sign": 1, "time_scale": "GPS",
                 "start_time": gps_time_iso(sidecar["gps_week"], sidecar["gps_seconds_of_week"])})
    full.setdefault("source", SOURCE)
    _atomic_write(path, payload)
    _atomic_write(sidecar_path(path), (json.dumps(full, indent=2, sort_keys=True) + "\n").encode())
    return full
