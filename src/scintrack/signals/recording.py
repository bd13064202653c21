"""Raw sample recordings (ours and other receivers'): the JSON sidecar that describes one, and the one reader.

A recording is a headerless binary file of samples plus a JSON sidecar
``<data file>.json`` beside it that says how to read it.  The same reader
serves the project's synthetic recordings (:func:`scintrack.signals.gps.iq.write_recording`)
and real captures of other front ends (``data/real/``).

Sidecar fields the reader needs (every other field is description and is
passed through untouched):

* ``format``: how the numbers are stored, one of :data:`FORMATS`: interleaved
  I, Q pairs (``int8``, little-endian ``int16``, little-endian ``float32``
  pairs = ``complex64``) or real-valued IF samples (``int8``, ``int16``,
  ``float32``).
* ``iq_sign`` (I/Q formats only): +1 or -1, the sample is ``z = I + iq_sign j Q``.
  Front ends differ (Pocket SDR writes ``I - jQ``); with the wrong sign every
  Doppler comes out negated.
* ``scale``: a stored number ``v`` is the value ``v / scale`` (1 for a
  receiver's raw ADC levels).
* ``n_samples``: how many samples (I/Q pairs for I/Q formats, numbers for
  real formats) the file holds; the file size must be exactly that.
* ``sha256``: of the data file; a changed byte is refused.
* ``sample_rate_hz``; ``intermediate_frequency_hz``: where the L1 carrier
  lands in the samples (0 for complex baseband; ``0 < IF < fs/2`` for real
  samples, ``|IF| < fs/2`` for I/Q); ``centre_frequency_hz``: the front end's
  local oscillator (RF ``f`` appears at ``f - centre_frequency_hz``, so for a
  non-inverting front end ``IF = 1575.42 MHz - centre_frequency_hz``).
* ``start_time`` (ISO 8601, e.g. ``2021-12-01T08:47:00Z``) and ``time_scale``
  (``"UTC"`` or ``"GPS"``) of the first sample; ``source``: who recorded or
  generated the samples.
* ``duration_s`` (optional): when present it must equal ``n_samples / sample_rate_hz``
  to within one sample.

:func:`read_recording` returns the samples as stored, scaled: complex64 for
I/Q formats (sign convention applied), float32 for real formats.  Real IF
samples are not mixed to baseband here: the carrier wipe-off in acquisition
and correlation multiplies by ``exp(-j 2 pi (IF + f_D) t)`` anyway, so one
multiplication does both, the reader stays a reader, and the real array takes
half the memory.  Anything that does not fit (no sidecar, a field missing or of
the wrong type, an unknown ``format``, a size that is not a whole number of
samples or differs from ``n_samples``, a wrong sha256) raises
:class:`IQFormatError`, one line naming the file and the field.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, one_line

DOC = "docs/real-signals.md"


class IQFormatError(InputError):
    """A recording or its sidecar that :func:`read_recording` cannot accept (missing, truncated, altered, mis-described)."""


@dataclass(frozen=True)
class SampleFormat:
    """How a ``format`` name stores samples: numpy dtype of one stored number, and whether numbers come in I, Q pairs."""

    dtype: str
    iq: bool

    @property
    def bytes_per_sample(self) -> int:
        return np.dtype(self.dtype).itemsize * (2 if self.iq else 1)


#: the accepted values of the sidecar's ``format`` field
FORMATS = {
    "int8 interleaved IQ": SampleFormat("i1", True),
    "int16 interleaved IQ little-endian": SampleFormat("<i2", True),
    "complex64 little-endian": SampleFormat("<f4", True),
    "int8 real": SampleFormat("i1", False),
    "int16 real little-endian": SampleFormat("<i2", False),
    "float32 real little-endian": SampleFormat("<f4", False),
}
#: fields every sidecar must hold (I/Q formats also ``iq_sign``)
REQUIRED = ("format", "sample_rate_hz", "intermediate_frequency_hz", "centre_frequency_hz", "n_samples", "scale", "sha256",
            "start_time", "time_scale", "source")
TIME_SCALES = ("UTC", "GPS")
_F32 = np.finfo(np.float32)


def sidecar_path(path: str | os.PathLike) -> Path:
    """``rec.bin`` -> ``rec.bin.json``."""
    path = Path(path)
    return path.with_name(path.name + ".json")


def _number(side: Path, meta: dict, key: str) -> float:
    value = meta[key]
    try:
        ok = not isinstance(value, bool) and isinstance(value, int | float) and math.isfinite(value) and abs(value) <= _F32.max
    except OverflowError:  # an integer too large for a float
        ok = False
    if not ok:
        raise IQFormatError(f"{side}: {key} must be a finite number (got {one_line(repr(value))[:60]}); fix the sidecar ({DOC})")
    return float(value)


def sample_format(meta: dict, side: Path) -> SampleFormat:
    """The :class:`SampleFormat` named by ``meta['format']``."""
    name = meta.get("format")
    if not isinstance(name, str) or name not in FORMATS:
        raise IQFormatError(f"{side}: format {one_line(repr(name))[:60]} is not one of {sorted(FORMATS)}; fix the sidecar ({DOC})")
    return FORMATS[name]


def check_sidecar(meta: object, side: Path) -> SampleFormat:
    """Validate the fields the reader needs (module docstring); returns the sample format."""
    if not isinstance(meta, dict):
        raise IQFormatError(f"sidecar {side} holds a JSON {type(meta).__name__}, not an object; rewrite it ({DOC})")
    missing = [key for key in REQUIRED if key not in meta]
    fmt = sample_format(meta, side) if "format" in meta else None
    if fmt is not None and fmt.iq and "iq_sign" not in meta:
        missing.append("iq_sign")
    if missing:
        raise IQFormatError(f"sidecar {side} lacks {missing}; add them ({DOC})")
    fs = _number(side, meta, "sample_rate_hz")
    if fs <= 0:
        raise IQFormatError(f"{side}: sample_rate_hz must be > 0 Hz (got {fs!r}); fix the sidecar")
    f_if = _number(side, meta, "intermediate_frequency_hz")
    if fmt.iq and not abs(f_if) < fs / 2:
        raise IQFormatError(f"{side}: intermediate_frequency_hz {f_if!r} must lie within +-sample_rate_hz/2 = {fs / 2!r} for I/Q samples; fix the sidecar")
    if not fmt.iq and not 0 < f_if < fs / 2:
        raise IQFormatError(f"{side}: intermediate_frequency_hz {f_if!r} must lie in (0, sample_rate_hz/2 = {fs / 2!r}) for real samples; fix the sidecar")
    if _number(side, meta, "centre_frequency_hz") <= 0:
        raise IQFormatError(f"{side}: centre_frequency_hz (the local oscillator) must be > 0 Hz; fix the sidecar")
    scale = meta["scale"]
    if isinstance(scale, bool) or not isinstance(scale, int | float) or not _F32.tiny <= scale <= _F32.max:  # NaN fails too
        raise IQFormatError(f"{side}: scale must be a positive number (got {one_line(repr(scale))[:60]}); fix the sidecar")
    n = meta["n_samples"]
    if isinstance(n, bool) or not isinstance(n, int) or n < 0:
        raise IQFormatError(f"{side}: n_samples must be a non-negative integer (got {one_line(repr(n))[:60]}); fix the sidecar")
    if not (isinstance(meta["sha256"], str) and re.fullmatch(r"[0-9a-f]{64}", meta["sha256"])):
        raise IQFormatError(f"{side}: sha256 must be 64 lower-case hex digits (the data file's sha256); fix the sidecar")
    if fmt.iq and (isinstance(meta["iq_sign"], bool) or meta["iq_sign"] not in (1, -1)):
        raise IQFormatError(f"{side}: iq_sign must be 1 (z = I + jQ) or -1 (z = I - jQ) (got {one_line(repr(meta['iq_sign']))[:40]}); fix the sidecar")
    try:
        dt.datetime.fromisoformat(meta["start_time"])
    except (TypeError, ValueError):
        raise IQFormatError(f"{side}: start_time must be an ISO 8601 time such as 2021-12-01T08:47:00Z "
                            f"(got {one_line(repr(meta['start_time']))[:60]}); fix the sidecar") from None
    if meta["time_scale"] not in TIME_SCALES:
        raise IQFormatError(f"{side}: time_scale must be one of {list(TIME_SCALES)} (got {one_line(repr(meta['time_scale']))[:40]}); fix the sidecar")
    if not isinstance(meta["source"], str) or not meta["source"].strip():
        raise IQFormatError(f"{side}: source must be a non-empty string saying who recorded the samples; fix the sidecar")
    if "duration_s" in meta:
        duration = _number(side, meta, "duration_s")
        if abs(duration * fs - n) > 1.0:
            raise IQFormatError(f"{side}: duration_s {duration!r} does not match n_samples / sample_rate_hz = {n / fs!r} s; fix the sidecar")
    return fmt


def read_sidecar(path: str | os.PathLike) -> tuple[dict, SampleFormat]:
    """The checked sidecar of the recording at ``path`` and its sample format (the data file is not read)."""
    path = Path(path)
    side = sidecar_path(path)
    if not side.is_file():
        raise IQFormatError(f"recording {path} has no sidecar {side}; write one beside it (fields in {DOC})")
    try:
        meta = json.loads(side.read_bytes())
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:  # RecursionError: absurdly deep nesting
        raise IQFormatError(f"sidecar {side} is not valid JSON ({one_line(exc)}); rewrite it ({DOC})") from None
    return meta, check_sidecar(meta, side)


def read_recording(path: str | os.PathLike) -> tuple[np.ndarray, dict]:
    """Samples and sidecar of a recording, after checking sidecar, size and sha256.

    I/Q formats give complex64 ``(I + iq_sign j Q) / scale``; real formats give
    float32 ``v / scale`` (still at the intermediate frequency).
    """
    path = Path(path)
    if not path.is_file():
        raise IQFormatError(f"recording data file {path} does not exist; put it there or fix the path")
    meta, fmt = read_sidecar(path)
    side = sidecar_path(path)
    payload = path.read_bytes()
    width, n = fmt.bytes_per_sample, meta["n_samples"]
    if len(payload) % width:
        raise IQFormatError(f"{path} holds {len(payload)} bytes, not a whole number of {width}-byte samples of format "
                            f"{meta['format']!r}: the file is truncated or the format in {side} is wrong")
    if len(payload) != width * n:
        kind = "shorter" if len(payload) < width * n else "longer"
        raise IQFormatError(f"{path} holds {len(payload)} bytes ({len(payload) // width} samples), {kind} than the n_samples = {n} "
                            f"({width * n} bytes) that {side} declares: the file is truncated or n_samples is wrong")
    digest = hashlib.sha256(payload).hexdigest()
    if digest != meta["sha256"]:
        raise IQFormatError(f"{path} is corrupted or was changed: sha256 {digest} != {meta['sha256']!r} in {side}")
    values = np.frombuffer(payload, dtype=fmt.dtype).astype(np.float32)
    values /= np.float32(meta["scale"])
    if not np.all(np.isfinite(values)):
        raise IQFormatError(f"{path}: samples / scale are not all finite float32 values; fix scale in {side} or the data")
    if not fmt.iq:
        return values, meta
    samples = values.view(np.complex64)
    if meta["iq_sign"] == -1:
        np.conjugate(samples, out=samples)
    return samples, meta
