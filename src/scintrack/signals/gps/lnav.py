"""GPS LNAV (L1 C/A, 50 bit/s) words and subframes 1-3: encoding and decoding.

IS-GPS-200 Rev D, Sec. 20.3 (layout of the reference notes, ``gps-lnav-mm.md`` Sec. 1):

* a word is 30 bits, MSB first: 24 data bits d1..d24 and parity D25..D30;
  a subframe is 10 words (300 bits, 6 s);
* parity (Table 20-XIV): every transmitted data bit is ``D_i = d_i xor D30*``
  and the six parity bits are the equations of :data:`PARITY_TAPS` with the
  last two bits ``D29*``, ``D30*`` of the previous word;
* the HOW (word 2, subframe bits 53-54) and word 10 (bits 293-294) carry two
  non-information bits solved so that ``D29 = D30 = 0``, so the TLM and
  word 3 of the next subframe are never inverted;
* word 1 (TLM): preamble ``10001011``, 14-bit TLM message, integrity flag,
  reserved bit; word 2 (HOW): 17-bit truncated TOW of the *next* subframe,
  alert and anti-spoof flags, subframe ID;
* subframes 1-3: the clock and ephemeris fields of :data:`FIELDS`, each a list
  of (first subframe bit, length) parts MSB first, a power-of-two scale and a
  two's-complement flag.  Values are in the spec's units (seconds, metres,
  semicircles, semicircles/s); :func:`quantise` rounds them to the integer the
  message carries.  Reserved bits of subframe 1 are sent as zeros (documented
  filler; the spec leaves their content open).

The TLM/HOW header (:func:`header_bits`) and the generic field packing
(:func:`pack_fields`, :func:`unpack_fields`) are shared with subframes 4 and 5,
whose 25 pages are in :mod:`scintrack.signals.gps.lnav_pages`; the whole
transmitted stream with data-set cutovers and uploads is in
:mod:`scintrack.signals.gps.message`.  Received bits that are not a stream of
0/1 values raise :class:`LNAVDecodeError`; bits that are 0/1 but fail parity
are data (the decoder reports the parity verdicts), not an error.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ...errors import InputError

PREAMBLE = 0b10001011
WORD_BITS = 30
SUBFRAME_BITS = 300

#: Parity equations (Table 20-XIV): (previous-word bit 29 or 30, data bits d_i xor-ed in).
PARITY_TAPS: tuple[tuple[int, tuple[int, ...]], ...] = (
    (29, (1, 2, 3, 5, 6, 10, 11, 12, 13, 14, 17, 18, 20, 23)),
    (30, (2, 3, 4, 6, 7, 11, 12, 13, 14, 15, 18, 19, 21, 24)),
    (29, (1, 3, 4, 5, 7, 8, 12, 13, 14, 15, 16, 19, 20, 22)),
    (30, (2, 4, 5, 6, 8, 9, 13, 14, 15, 16, 17, 20, 21, 23)),
    (30, (1, 3, 5, 6, 7, 9, 10, 14, 15, 16, 17, 18, 21, 22, 24)),
    (29, (3, 5, 6, 8, 9, 10, 11, 13, 15, 19, 22, 23, 24)),
)


class LNAVDecodeError(InputError):
    """Received LNAV bits that are not a stream of 0/1 values (or not a whole subframe where one is needed)."""


@dataclass(frozen=True)
class Field:
    """One message field: parts (first subframe bit, length), MSB part first; LSB weight 2**scale."""

    parts: tuple[tuple[int, int], ...]
    scale: int = 0
    signed: bool = False

    @property
    def bits(self) -> int:
        return sum(n for _, n in self.parts)


#: Subframes 1-3 fields (Tables 20-I and 20-III), subframe bit numbers 1..300.
FIELDS: dict[int, dict[str, Field]] = {
    1: {
        "wn": Field(((61, 10),)),
        "l2_code": Field(((71, 2),)),
        "ura": Field(((73, 4),)),
        "health": Field(((77, 6),)),
        "iodc": Field(((83, 2), (211, 8))),
        "l2p_flag": Field(((91, 1),)),
        "t_gd": Field(((197, 8),), -31, True),
        "t_oc": Field(((219, 16),), 4),
        "a_f2": Field(((241, 8),), -55, True),
        "a_f1": Field(((249, 16),), -43, True),
        "a_f0": Field(((271, 22),), -31, True),
    },
    2: {
        "iode": Field(((61, 8),)),
        "c_rs": Field(((69, 16),), -5, True),
        "delta_n": Field(((91, 16),), -43, True),
        "m0": Field(((107, 8), (121, 24)), -31, True),
        "c_uc": Field(((151, 16),), -29, True),
        "e": Field(((167, 8), (181, 24)), -33),
        "c_us": Field(((211, 16),), -29, True),
        "sqrt_a": Field(((227, 8), (241, 24)), -19),
        "t_oe": Field(((271, 16),), 4),
        "fit_flag": Field(((287, 1),)),
        "aodo": Field(((288, 5),)),
    },
    3: {
        "c_ic": Field(((61, 16),), -29, True),
        "omega0": Field(((77, 8), (91, 24)), -31, True),
        "c_is": Field(((121, 16),), -29, True),
        "i0": Field(((137, 8), (151, 24)), -31, True),
        "c_rc": Field(((181, 16),), -5, True),
        "omega": Field(((197, 8), (211, 24)), -31, True),
        "omega_dot": Field(((241, 24),), -43, True),
        "iode": Field(((271, 8),)),
        "idot": Field(((279, 14),), -43, True),
    },
}


#: :data:`PARITY_TAPS` as (previous-word bit, mask of the data bits d_i at bit 24 - i)
_PARITY_MASKS = tuple((prev_bit, sum(1 << (24 - i) for i in taps)) for prev_bit, taps in PARITY_TAPS)


def parity(data24: int, d29s: int, d30s: int) -> int:
    """Parity bits D25..D30 (6-bit integer, D25 first) of the source data d1..d24.

    Each bit is the previous word's D29* or D30* XOR the parity (popcount mod 2)
    of the tapped data bits.
    """
    out = 0
    for prev_bit, mask in _PARITY_MASKS:
        p = (d29s if prev_bit == 29 else d30s) ^ ((data24 & mask).bit_count() & 1)
        out = (out << 1) | p
    return out


def encode_word(data24: int, d29s: int, d30s: int) -> int:
    """Transmitted 30-bit word: data inverted when D30* = 1, then parity."""
    sent = data24 ^ (0xFFFFFF if d30s else 0)
    return (sent << 6) | parity(data24, d29s, d30s)


def decode_word(word30: int, d29s: int, d30s: int) -> tuple[int, bool]:
    """Source data d1..d24 of a received word and whether its parity holds."""
    data24 = (word30 >> 6) ^ (0xFFFFFF if d30s else 0)
    return data24, parity(data24, d29s, d30s) == (word30 & 0x3F)


def _solve_last_two_bits(data24: int, d29s: int, d30s: int) -> int:
    """Set d23, d24 so that the transmitted D29 = D30 = 0 (HOW and word 10)."""
    for t in range(4):
        candidate = (data24 & ~0b11) | t
        if encode_word(candidate, d29s, d30s) & 0b11 == 0:
            return candidate
    raise AssertionError("no non-information bits give D29 = D30 = 0")  # cannot happen: the map is onto


def quantise(value: float, field: Field) -> int:
    """The integer a field carries for ``value`` (two's complement for signed fields)."""
    n = round(value / 2.0**field.scale)
    lo, hi = (-(1 << (field.bits - 1)), (1 << (field.bits - 1)) - 1) if field.signed else (0, (1 << field.bits) - 1)
    if not lo <= n <= hi:
        raise ValueError(f"{value!r} does not fit in {field.bits} bits at scale 2^{field.scale}")
    return n & ((1 << field.bits) - 1)


def dequantise(raw: int, field: Field) -> float:
    if field.signed and raw >> (field.bits - 1):
        raw -= 1 << field.bits
    return raw * 2.0**field.scale


def _put(bits: list[int], first: int, length: int, value: int) -> None:
    for k in range(length):
        bits[first - 1 + k] = (value >> (length - 1 - k)) & 1


def _get(bits: Sequence[int], first: int, length: int) -> int:
    value = 0
    for k in range(length):
        value = (value << 1) | int(bits[first - 1 + k])
    return value


def _pack(bits: list[int], field: Field, raw: int) -> None:
    remaining = field.bits
    for first, length in field.parts:
        remaining -= length
        _put(bits, first, length, (raw >> remaining) & ((1 << length) - 1))


def _unpack(bits: Sequence[int], field: Field) -> int:
    raw = 0
    for first, length in field.parts:
        raw = (raw << length) | _get(bits, first, length)
    return raw


def subframe_id(t0: int) -> int:
    """Subframe ID of the subframe starting at time of week ``t0`` (a multiple of 6 s)."""
    return (t0 // 6) % 5 + 1


def how_tow(t0: int) -> int:
    """HOW TOW: the 17 MSBs of the TOW count at the start of the next subframe."""
    return ((t0 + 6) // 6) % 100800


def header_bits(
    t0: int, *, tlm_message: int = 0, integrity: int = 0, alert: int = 0, anti_spoof: int = 1,
) -> list[int]:
    """300 source bits of the subframe starting at ``t0`` with only the TLM and HOW filled (all other bits 0)."""
    if t0 % 6 or not 0 <= t0 < 604800:
        raise ValueError(f"t0 = {t0}: a subframe starts at a multiple of 6 s within the week [0, 604800)")
    bits = [0] * SUBFRAME_BITS
    _put(bits, 1, 8, PREAMBLE)
    _put(bits, 9, 14, tlm_message)
    _put(bits, 23, 1, integrity)
    _put(bits, 31, 17, how_tow(t0))
    _put(bits, 48, 1, alert)
    _put(bits, 49, 1, anti_spoof)
    _put(bits, 50, 3, subframe_id(t0))
    return bits


def pack_fields(bits: list[int], table: Mapping[str, Field], values: Mapping[str, float], where: str = "subframe") -> None:
    """Write every field of ``table`` from ``values`` (spec units; unscaled unsigned fields as integers) into ``bits``."""
    missing = sorted(set(table) - set(values))
    if missing:
        raise ValueError(f"{where}: missing fields {missing}")
    for name, field in table.items():
        _pack(bits, field, raw_value(values[name], field, f"{where}: {name}"))


def raw_value(value: float, field: Field, where: str = "field") -> int:
    """The integer ``field`` carries for ``value`` (unscaled unsigned fields as integers); ValueError if it does not fit."""
    if not math.isfinite(value):
        raise ValueError(f"{where} = {value!r} is not a finite number")
    try:
        raw = int(value) if field.scale == 0 and not field.signed else quantise(float(value), field)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None
    if not 0 <= raw < 1 << field.bits:
        raise ValueError(f"{where} = {value!r} does not fit in {field.bits} bits")
    return raw


def unpack_fields(source: Sequence[int], table: Mapping[str, Field]) -> dict[str, float]:
    """Fields of ``table`` read from source bits: integers for unscaled unsigned fields, spec units otherwise."""
    out: dict[str, float] = {}
    for name, field in table.items():
        raw = _unpack(source, field)
        out[name] = raw if field.scale == 0 and not field.signed else dequantise(raw, field)
    return out


def source_bits(
    t0: int, fields: Mapping[str, float], *, tlm_message: int = 0, integrity: int = 0, alert: int = 0, anti_spoof: int = 1,
) -> list[int]:
    """The 300 source bits of the subframe (1, 2 or 3) starting at ``t0``, parity positions left 0."""
    sf = subframe_id(t0)
    if sf not in FIELDS:
        raise ValueError(f"t0 = {t0} s starts subframe {sf}; only subframes 1-3 are encoded here")
    bits = header_bits(t0, tlm_message=tlm_message, integrity=integrity, alert=alert, anti_spoof=anti_spoof)
    pack_fields(bits, FIELDS[sf], fields, where=f"subframe {sf}")
    return bits


def encode_subframe(source: Sequence[int], d29s: int = 0, d30s: int = 0) -> list[int]:
    """Transmitted 300 bits: parity chained from the previous word's (D29*, D30*); HOW and word 10 solved."""
    out: list[int] = []
    for w in range(10):
        data24 = _get(source, 30 * w + 1, 24)
        if w in (1, 9):
            data24 = _solve_last_two_bits(data24, d29s, d30s)
        word = encode_word(data24, d29s, d30s)
        out += [(word >> (29 - k)) & 1 for k in range(30)]
        d29s, d30s = (word >> 1) & 1, word & 1
    return out


def decode_subframe(sent: Sequence[int], d29s: int = 0, d30s: int = 0) -> tuple[list[int], list[bool]]:
    """Source bits (parity positions zeroed) and the parity verdict of each word.

    The 300 bits are read into one integer at once and each word's 24 data bits
    written back through a byte table: the same words, data and verdicts as
    reading and writing bit by bit (:func:`_get`, :func:`_put`), at a quarter
    of the Python operations (the Zhao receiver decodes ~7000 subframes per job).
    """
    if len(sent) != SUBFRAME_BITS:
        raise LNAVDecodeError(f"sent: a subframe is {SUBFRAME_BITS} bits, got {len(sent)}; pass one whole subframe")
    try:
        value = int(bytes(sent if isinstance(sent, list) else list(sent)).translate(_BIT_DIGITS), 2)
    except (TypeError, ValueError):
        raise LNAVDecodeError("sent: bits must be 0 or 1") from None
    source: list[int] = []
    ok = []
    for w in range(10):
        word = (value >> (30 * (9 - w))) & 0x3FFFFFFF
        data24, good = decode_word(word, d29s, d30s)
        source += _BYTE_BITS[data24 >> 16] + _BYTE_BITS[(data24 >> 8) & 0xFF] + _BYTE_BITS[data24 & 0xFF] + _SIX_ZEROS
        ok.append(good)
        d29s, d30s = (word >> 1) & 1, word & 1
    return source, ok


#: :func:`decode_subframe`'s tables: byte 0/1 -> ASCII digit, any other byte -> "x" (rejected by ``int``),
#: and the eight bits of each byte value, most significant first.
_BIT_DIGITS = bytes.maketrans(bytes(range(256)), b"01" + b"x" * 254)
_BYTE_BITS = tuple([(v >> (7 - k)) & 1 for k in range(8)] for v in range(256))
_SIX_ZEROS = [0] * 6


def read_fields(source: Sequence[int]) -> dict[str, float]:
    """Header and clock/ephemeris fields of a decoded subframe 1-3, in the spec's units."""
    sf = _get(source, 50, 3)
    out: dict[str, float] = {"preamble": _get(source, 1, 8), "tow17": _get(source, 31, 17), "subframe_id": sf}
    out.update(unpack_fields(source, FIELDS.get(sf, {})))
    return out
