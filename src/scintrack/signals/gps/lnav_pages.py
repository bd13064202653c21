"""GPS LNAV subframes 4 and 5: the 25 sub-commutated pages, their encoding and decoding.

IS-GPS-200 Rev D, Sec. 20.3.3.5 (layouts in ``gps-lnav-mm.md`` Sec. 1.2; the
bit positions below were cross-checked against the field extraction of
gpsd's ``subframe.c``):

* paging: the frame starting at time of week ``t`` carries page
  ``(floor(t/30) mod 25) + 1`` of both subframes (Sec. 20.3.4.1; paging
  restarts with page 1 at the start of every week);
* word 3 of every page starts with the data ID ``01`` (bits 61-62) and the
  SV ID (bits 63-68), Table 20-V: the PRN on almanac pages (subframe 5 pages
  1-24 -> SV 1-24, subframe 4 pages 2-5, 7-10 -> SV 25-32), the page ID
  otherwise (:data:`SF4_SV_ID`, subframe 5 page 25 -> 51);
* almanac page (Fig. 20-1 sheet 4, Table 20-VI): e (16 b, 2^-21), t_oa
  (8 b, 2^12 s), delta_i (16 b, 2^-19 sc, relative to i0 = 0.30 sc), OMEGADOT
  (16 b, 2^-38 sc/s), health (8 b), sqrt(A) (24 b, 2^-11), OMEGA0, omega, M0
  (24 b, 2^-23 sc), a_f0 (11 b, 2^-20 s: 8 MSBs in bits 271-278, 3 LSBs in
  290-292) and a_f1 (11 b, 2^-38, bits 279-289);
* subframe 5 page 25: t_oa, WN_a (8 b each) and the 6-bit health of SV 1-24;
* subframe 4 page 25: 4-bit A-S flag / configuration words of SV 1-32, two
  reserved bits, the 6-bit health of SV 25-32, four reserved bits;
* subframe 4 page 18: Klobuchar alpha0..3 (2^-30, 2^-27, 2^-24, 2^-24 s/sc^n),
  beta0..3 (2^11, 2^14, 2^16, 2^16 s/sc^n), A1 (24 b, 2^-50), A0 (32 b,
  2^-30), t_ot (2^12 s), WN_t, dt_LS, WN_LSF, DN, dt_LSF (8 b each); 14 reserved bits;
* subframe 4 page 13 (NMCT): 2-bit availability indicator and thirty 6-bit
  ERDs; page 17: 22 eight-bit characters and 6 reserved bits.

The almanac is built from the same broadcast ephemerides
(:func:`almanac_fields`): for each PRN the data set whose t_oe is nearest the
almanac reference time t_oa is propagated to t_oa with the ephemeris' own
model (M0 += n (t_oa - t_oe) with the corrected mean motion
n = sqrt(mu/A^3) + delta_n, OMEGA0 += OMEGADOT (t_oa - t_oe), i += IDOT
(t_oa - t_oe), clock polynomial re-referenced from t_oc to t_oa) and rounded to
almanac precision; e, sqrt(A), omega and OMEGADOT are copied.  Choices the spec
leaves open, with reasons:

* t_oa (default): the multiple of 2^12 s nearest the middle of the span of the
  file's t_oe, so every data set used is at most half a file away, and every
  satellite's stream carries the same almanac as in reality; WN_a = that
  week mod 256.
* Health: the 6-bit page-25 word is the subframe-1 health of that data set
  (same format: summary bit + 5-bit signal code); the 8-bit almanac health
  has NAV-data bits ``000`` (all data OK) when the summary bit is 0 and
  ``111`` (all data bad) when it is 1, followed by the same 5 signal bits.
* A PRN absent from the file is a dummy SV (Sec. 20.3.3.5.1.1-2): its almanac
  page carries SV ID 0 and alternating ones and zeros (``1010...``, d1 = 1 in
  every word) with valid parity; its page-25 health is ``111111`` and its
  configuration word ``0000`` (A-S off, reserved configuration code: no SV).
* Configuration words of present SVs default to ``1001`` (A-S on, code 001 =
  the Block II capability set every operational SV has), matching the HOW's
  A-S flag 1; a per-PRN override is accepted.
* NMCT (page 13): availability indicator ``10`` ("no correction table
  available") and every ERD ``100000`` ("no valid ERD"); a simulator has no
  precise orbits to form ERDs, and this is the spec's own way to say so.
* Special message (page 17): 22 blanks unless given (upper-case letters,
  digits, blank and ``+-./:'"``).
* Reserved and system-use pages (subframe 4 pages 1, 6, 11, 12, 14-16, 19-24):
  data ID, their Table 20-V SV ID, then the same alternating pattern as a
  dummy almanac (a defined, parity-valid filler).  Reserved bits inside the
  defined pages are zeros, as for subframe 1 in :mod:`lnav`.
* UTC page: dt_LS is the header's LEAP SECONDS; RINEX 2 carries no WN_LSF,
  DN, dt_LSF, so the most recent past leap-second event is sent
  (:data:`LEAP_SECOND_DATES`, from the IERS announcements), with
  dt_LSF = dt_LS, which says that no leap second is pending (true in
  October 2015: the next one was announced in 2016).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from . import lnav
from .ephemeris import GPS_EPOCH, GPS_PI, SECONDS_PER_WEEK, Ephemeris, NavHeader, by_prn
from .lnav import Field

#: WGS 84 earth gravitational constant of the user algorithm (Table 20-IV), m^3/s^2.
MU = 3.986005e14
#: Reference inclination of the almanac's delta_i, semicircles (Table 20-VI note).
I0_REF = 0.30
#: Almanac reference time LSB, s.
T_OA_LSB = 4096
DATA_ID = 0b01
DUMMY_SV_ID = 0
#: Table 20-V: SV ID of each subframe 4 page 1..25.
SF4_SV_ID = (57, 25, 26, 27, 28, 57, 29, 30, 31, 32, 57, 62, 52, 53, 54, 57, 55, 56, 58, 59, 57, 60, 61, 62, 63)
SF5_PAGE25_SV_ID = 51
#: Subframe 4 pages carrying almanacs, page -> PRN.
SF4_ALMANAC_PAGES = {2: 25, 3: 26, 4: 27, 5: 28, 7: 29, 8: 30, 9: 31, 10: 32}
ABSENT_HEALTH = 0b111111
ABSENT_CONFIG = 0b0000
DEFAULT_CONFIG = 0b1001
NMCT_NO_TABLE = 0b10
ERD_INVALID = 0b100000
SPECIAL_CHARACTERS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 +-./:'\"")
#: First UTC day with GPS-UTC = n whole seconds, n = 1..18 (IERS Bulletin C); the leap second ends the day before.
LEAP_SECOND_DATES = tuple(
    np.datetime64(d)
    for d in (
        "1981-07-01", "1982-07-01", "1983-07-01", "1985-07-01", "1988-01-01", "1990-01-01", "1991-01-01", "1992-07-01",
        "1993-07-01", "1994-07-01", "1996-01-01", "1997-07-01", "1999-01-01", "2006-01-01", "2009-01-01", "2012-07-01",
        "2015-07-01", "2017-01-01",
    )
)

# Subframe bit numbers of the 240 data bits d1..d24 of words 1..10, to lay fields along the data stream.
_DATA_BITS = tuple(30 * w + b for w in range(10) for b in range(1, 25))
_DATA_INDEX = {n: k for k, n in enumerate(_DATA_BITS)}


def _span(first_bit: int, length: int, skip: int = 0) -> tuple[tuple[int, int], ...]:
    """Field parts of ``length`` consecutive data bits starting ``skip`` data bits after subframe bit ``first_bit``."""
    start = _DATA_INDEX[first_bit] + skip
    bits = _DATA_BITS[start : start + length]
    parts: list[list[int]] = []
    for n in bits:
        if parts and parts[-1][0] + parts[-1][1] == n:
            parts[-1][1] += 1
        else:
            parts.append([n, 1])
    return tuple((a, b) for a, b in parts)


HEADER_FIELDS = {"data_id": Field(((61, 2),)), "sv_id": Field(((63, 6),))}

ALMANAC_FIELDS = {
    "e": Field(_span(69, 16), -21),
    "t_oa": Field(_span(91, 8), 12),
    "delta_i": Field(_span(99, 16), -19, True),
    "omega_dot": Field(_span(121, 16), -38, True),
    "health": Field(_span(137, 8)),
    "sqrt_a": Field(_span(151, 24), -11),
    "omega0": Field(_span(181, 24), -23, True),
    "omega": Field(_span(211, 24), -23, True),
    "m0": Field(_span(241, 24), -23, True),
    "a_f0": Field(((271, 8), (290, 3)), -20, True),
    "a_f1": Field(_span(279, 11), -38, True),
}

SF5_PAGE25_FIELDS = {
    "t_oa": Field(_span(69, 8), 12),
    "wn_a": Field(_span(77, 8)),
    **{f"health_{k}": Field(_span(91, 6, 6 * (k - 1))) for k in range(1, 25)},
}

SF4_PAGE25_FIELDS = {
    **{f"config_{k}": Field(_span(69, 4, 4 * (k - 1))) for k in range(1, 33)},
    **{f"health_{k}": Field(_span(229, 6, 6 * (k - 25))) for k in range(25, 33)},
}

IONO_UTC_FIELDS = {
    "alpha0": Field(_span(69, 8), -30, True),
    "alpha1": Field(_span(77, 8), -27, True),
    "alpha2": Field(_span(91, 8), -24, True),
    "alpha3": Field(_span(99, 8), -24, True),
    "beta0": Field(_span(107, 8), 11, True),
    "beta1": Field(_span(121, 8), 14, True),
    "beta2": Field(_span(129, 8), 16, True),
    "beta3": Field(_span(137, 8), 16, True),
    "a1": Field(_span(151, 24), -50, True),
    "a0": Field(_span(181, 32), -30, True),
    "t_ot": Field(_span(219, 8), 12),
    "wn_t": Field(_span(227, 8)),
    "dt_ls": Field(_span(241, 8), 0, True),
    "wn_lsf": Field(_span(249, 8)),
    "dn": Field(_span(257, 8)),
    "dt_lsf": Field(_span(271, 8), 0, True),
}

NMCT_FIELDS = {"ai": Field(_span(69, 2)), **{f"erd_{k}": Field(_span(71, 6, 6 * (k - 1))) for k in range(1, 31)}}

SPECIAL_FIELDS = {f"char_{k}": Field(_span(69, 8, 8 * (k - 1))) for k in range(1, 23)}

#: Page kind -> field table (dummy and reserved pages carry only the filler pattern).
PAGE_FIELDS: dict[str, dict[str, Field]] = {
    "almanac": ALMANAC_FIELDS,
    "health_sf5": SF5_PAGE25_FIELDS,
    "config_health_sf4": SF4_PAGE25_FIELDS,
    "iono_utc": IONO_UTC_FIELDS,
    "nmct": NMCT_FIELDS,
    "special": SPECIAL_FIELDS,
    "dummy": {},
    "reserved": {},
}


def page_number(t0: float) -> int:
    """Page (1..25) of subframes 4 and 5 in the frame containing time of week ``t0``."""
    return int(math.floor(t0 / 30.0)) % 25 + 1


def page_kind(subframe: int, page: int) -> tuple[str, int]:
    """(kind, nominal SV ID) of page ``page`` of subframe 4 or 5 (Table 20-V); almanac pages give the PRN."""
    if not 1 <= page <= 25:
        raise ValueError(f"page = {page}: pages are numbered 1..25")
    if subframe == 5:
        return ("health_sf5", SF5_PAGE25_SV_ID) if page == 25 else ("almanac", page)
    if subframe != 4:
        raise ValueError(f"subframe = {subframe}: only subframes 4 and 5 carry pages")
    sv = SF4_SV_ID[page - 1]
    kind = {25: "config_health_sf4", 18: "iono_utc", 13: "nmct", 17: "special"}.get(page, "reserved")
    return ("almanac", sv) if page in SF4_ALMANAC_PAGES else (kind, sv)


def wrap_semicircles(x: float) -> float:
    """Angle in semicircles wrapped to [-1, 1)."""
    return (x + 1.0) % 2.0 - 1.0


def reference_times(eph: Ephemeris) -> tuple[float, float]:
    """(t_oe, t_oc) of a data set in GPS seconds since the GPS epoch (``eph.week`` is the week of t_oc)."""
    t_oc = eph.week * SECONDS_PER_WEEK + eph.t_oc
    d = eph.t_oe - eph.t_oc
    d -= SECONDS_PER_WEEK * round(d / SECONDS_PER_WEEK)
    return t_oc + d, t_oc


def corrected_mean_motion(fields: Mapping[str, float]) -> float:
    """n = sqrt(mu/A^3) + delta_n of a data set, semicircles/s (Table 20-IV)."""
    a = float(fields["sqrt_a"]) ** 2
    return math.sqrt(MU / a**3) / GPS_PI + float(fields["delta_n"])


def almanac_fields(eph: Ephemeris, wn_a: int, t_oa: int) -> dict[str, float]:
    """Almanac of one data set propagated to (full week ``wn_a``, ``t_oa``), in the spec's units (not yet rounded)."""
    f = eph.fields
    t_oe_abs, t_oc_abs = reference_times(eph)
    t_ref = wn_a * SECONDS_PER_WEEK + t_oa
    dt_e, dt_c = t_ref - t_oe_abs, t_ref - t_oc_abs
    h = int(f["health"])
    return {
        "e": float(f["e"]),
        "t_oa": float(t_oa),
        "delta_i": float(f["i0"]) + float(f["idot"]) * dt_e - I0_REF,
        "omega_dot": float(f["omega_dot"]),
        "health": (0b111 << 5 if h >> 5 else 0) | (h & 0x1F),
        "sqrt_a": float(f["sqrt_a"]),
        "omega0": wrap_semicircles(float(f["omega0"]) + float(f["omega_dot"]) * dt_e),
        "omega": float(f["omega"]),
        "m0": wrap_semicircles(float(f["m0"]) + corrected_mean_motion(f) * dt_e),
        "a_f0": float(f["a_f0"]) + float(f["a_f1"]) * dt_c + float(f["a_f2"]) * dt_c**2,
        "a_f1": float(f["a_f1"]) + 2.0 * float(f["a_f2"]) * dt_c,
    }


def leap_second_event(dt_ls: int) -> tuple[int, int]:
    """(full GPS week, day number 1 = Sunday .. 7) at the end of which GPS-UTC became ``dt_ls`` s."""
    if not 1 <= dt_ls <= len(LEAP_SECOND_DATES):
        raise ValueError(f"dt_ls = {dt_ls}: no leap-second date known; pass wn_lsf and dn explicitly")
    last_day = LEAP_SECOND_DATES[dt_ls - 1] - np.timedelta64(1, "D")
    days = int((last_day - GPS_EPOCH.astype("datetime64[D]")).astype(int))
    return days // 7, days % 7 + 1


def iono_utc_fields(header: NavHeader, *, dt_lsf: int | None = None, wn_lsf: int | None = None, dn: int | None = None) -> dict[str, float]:
    """Page 18 fields from a RINEX header; leap-second event defaults to the most recent past one (module docstring)."""
    if header.t_ot % T_OA_LSB:
        raise ValueError(f"header t_ot = {header.t_ot} s is not a multiple of 2^12 s; the LNAV page cannot carry it")
    if wn_lsf is None or dn is None:
        week, day = leap_second_event(header.leap_seconds)
        wn_lsf = week if wn_lsf is None else wn_lsf
        dn = day if dn is None else dn
    values = {f"alpha{k}": header.alpha[k] for k in range(4)}
    values.update({f"beta{k}": header.beta[k] for k in range(4)})
    values.update(
        a0=header.a0, a1=header.a1, t_ot=float(header.t_ot), wn_t=header.wn_t % 256, dt_ls=float(header.leap_seconds),
        wn_lsf=wn_lsf % 256, dn=dn, dt_lsf=float(header.leap_seconds if dt_lsf is None else dt_lsf),
    )
    return values


@dataclass(frozen=True)
class PageData:
    """Everything subframes 4 and 5 carry.

    ``almanac`` maps PRN (1..32) to :data:`ALMANAC_FIELDS` values (a PRN not in
    it is a dummy SV); ``health``/``sv_config`` hold the 6-bit page-25 health
    and 4-bit A-S/configuration words of SV 1..32; ``wn_a`` is the 8-bit week.
    """

    almanac: Mapping[int, Mapping[str, float]]
    t_oa: int
    wn_a: int
    health: tuple[int, ...]
    sv_config: tuple[int, ...]
    iono_utc: Mapping[str, float]
    special_message: str = " " * 22
    nmct_ai: int = NMCT_NO_TABLE

    def __post_init__(self) -> None:
        if len(self.health) != 32 or len(self.sv_config) != 32:
            raise ValueError("PageData: health and sv_config need one entry per SV 1..32")
        if bad := sorted(set(self.almanac) - set(range(1, 33))):
            raise ValueError(f"PageData.almanac: PRNs {bad} are outside 1..32")
        if len(self.special_message) > 22 or not set(self.special_message) <= SPECIAL_CHARACTERS:
            raise ValueError(f"special_message {self.special_message!r}: at most 22 of the characters {''.join(sorted(SPECIAL_CHARACTERS))}")
        if self.t_oa % T_OA_LSB or not 0 <= self.t_oa <= 602112:
            raise ValueError(f"t_oa = {self.t_oa}: a multiple of 4096 s in [0, 602112]")


def default_almanac_epoch(ephemerides: Sequence[Ephemeris]) -> tuple[int, int]:
    """(full week, t_oa): the multiple of 2^12 s nearest the middle of the ephemerides' t_oe span."""
    toes = [reference_times(e)[0] for e in ephemerides]
    mid = 0.5 * (min(toes) + max(toes))
    week = int(mid // SECONDS_PER_WEEK)
    t_oa = T_OA_LSB * round((mid - week * SECONDS_PER_WEEK) / T_OA_LSB)
    if t_oa > 602112:  # 602112 + 4096 passes the end of the week
        week, t_oa = week + 1, 0
    return week, int(t_oa)


def build_page_data(
    ephemerides: Sequence[Ephemeris],
    header: NavHeader,
    *,
    almanac_epoch: tuple[int, int] | None = None,
    sv_config: Mapping[int, int] | None = None,
    special_message: str = "",
    dt_lsf: int | None = None,
    wn_lsf: int | None = None,
    dn: int | None = None,
) -> PageData:
    """Subframe 4/5 content from the broadcast ephemerides and the RINEX header (choices in the module docstring).

    ``almanac_epoch`` is (full week, t_oa); by default :func:`default_almanac_epoch`.
    """
    if not ephemerides:
        raise ValueError("ephemerides: empty; pass the data sets of a navigation file")
    wn_a, t_oa = default_almanac_epoch(ephemerides) if almanac_epoch is None else almanac_epoch
    t_ref = wn_a * SECONDS_PER_WEEK + t_oa
    almanac, health, config = {}, [ABSENT_HEALTH] * 32, [ABSENT_CONFIG] * 32
    for prn, sets in by_prn(list(ephemerides)).items():
        if not 1 <= prn <= 32:
            continue
        nearest = min(sets, key=lambda e: (abs(reference_times(e)[0] - t_ref), reference_times(e)[0]))
        almanac[prn] = almanac_fields(nearest, wn_a, t_oa)
        health[prn - 1] = int(nearest.fields["health"])
        config[prn - 1] = DEFAULT_CONFIG
    for prn, word in (sv_config or {}).items():
        if not (1 <= prn <= 32 and 0 <= word < 16):
            raise ValueError(f"sv_config[{prn}] = {word}: PRN 1..32 and a 4-bit word")
        config[prn - 1] = word
    pages = PageData(
        almanac=almanac, t_oa=t_oa, wn_a=wn_a % 256, health=tuple(health), sv_config=tuple(config),
        iono_utc=iono_utc_fields(header, dt_lsf=dt_lsf, wn_lsf=wn_lsf, dn=dn), special_message=special_message.ljust(22),
    )
    for sf in (4, 5):  # fail here, not mid-stream, if the file holds a value a page cannot carry
        for page in range(1, 26):
            _page_content(pages, sf, page)
    return pages


def _alternating(bits: list[int]) -> None:
    """Fill words 3-10 (after the data/SV ID, before word 10's solved bits) with d_i = 1 for odd i."""
    for n in _DATA_BITS[2 * 24 + 8 : 10 * 24 - 2]:
        bits[n - 1] = (((n - 1) % 30) + 1) % 2


def _page_content(pages: PageData, subframe: int, page: int) -> list[int]:
    """Words 3-10 of a page (source bits, TLM and HOW left 0)."""
    kind, sv_id = page_kind(subframe, page)
    bits = [0] * lnav.SUBFRAME_BITS
    values: Mapping[str, float] = {}
    if kind == "almanac" and sv_id not in pages.almanac:
        kind, sv_id = "dummy", DUMMY_SV_ID
    if kind in ("dummy", "reserved"):
        _alternating(bits)
    elif kind == "almanac":
        values = pages.almanac[sv_id]
    elif kind == "health_sf5":
        values = {"t_oa": pages.t_oa, "wn_a": pages.wn_a, **{f"health_{k}": pages.health[k - 1] for k in range(1, 25)}}
    elif kind == "config_health_sf4":
        values = {**{f"config_{k}": pages.sv_config[k - 1] for k in range(1, 33)}, **{f"health_{k}": pages.health[k - 1] for k in range(25, 33)}}
    elif kind == "iono_utc":
        values = pages.iono_utc
    elif kind == "nmct":
        values = {"ai": pages.nmct_ai, **{f"erd_{k}": ERD_INVALID for k in range(1, 31)}}
    elif kind == "special":
        values = {f"char_{k}": ord(c) for k, c in enumerate(pages.special_message.ljust(22), start=1)}
    lnav.pack_fields(bits, PAGE_FIELDS[kind], values, where=f"subframe {subframe} page {page} ({kind})")
    lnav.pack_fields(bits, HEADER_FIELDS, {"data_id": DATA_ID, "sv_id": sv_id})
    return bits


def page_source_bits(
    t0: int, pages: PageData, *, tlm_message: int = 0, integrity: int = 0, alert: int = 0, anti_spoof: int = 1,
) -> list[int]:
    """The 300 source bits of the subframe 4 or 5 starting at ``t0`` (parity positions 0)."""
    sf = lnav.subframe_id(t0)
    if sf not in (4, 5):
        raise ValueError(f"t0 = {t0} s starts subframe {sf}; pages are subframes 4 and 5")
    bits = lnav.header_bits(t0, tlm_message=tlm_message, integrity=integrity, alert=alert, anti_spoof=anti_spoof)
    content = _page_content(pages, sf, page_number(t0))
    return bits[:60] + content[60:]


def _is_alternating(source: Sequence[int]) -> bool:
    ref = [0] * lnav.SUBFRAME_BITS
    _alternating(ref)
    return all(source[n - 1] == ref[n - 1] for n in _DATA_BITS[2 * 24 + 8 : 10 * 24 - 2])


def read_page(source: Sequence[int], page: int | None = None) -> dict[str, object]:
    """Decoded subframe 4/5 page: header, ``kind``, and its fields in the spec's units.

    ``page`` (from time, :func:`page_number`) is only needed to tell which
    reserved page an SV ID 57/62 is; dummy and reserved pages report
    ``filler_ok`` (the alternating pattern is intact).
    """
    out: dict[str, object] = lnav.read_fields(source)  # preamble, tow17, subframe_id
    out.update(lnav.unpack_fields(source, HEADER_FIELDS))
    sf, sv = int(out["subframe_id"]), int(out["sv_id"])
    if sf == 5:
        kind = "health_sf5" if sv == SF5_PAGE25_SV_ID else "almanac"
    elif sf == 4:
        kind = {63: "config_health_sf4", 56: "iono_utc", 52: "nmct", 55: "special"}.get(sv, "almanac" if 25 <= sv <= 32 else "reserved")
    else:
        raise ValueError(f"source: subframe {sf} has no pages")
    if sv == DUMMY_SV_ID:
        kind = "dummy"
    out["kind"] = kind
    out["page"] = page
    fields = lnav.unpack_fields(source, PAGE_FIELDS[kind])
    for name, f in PAGE_FIELDS[kind].items():
        if f.scale >= 0:
            fields[name] = int(fields[name])
    out.update(fields)
    if kind in ("dummy", "reserved"):
        out["filler_ok"] = _is_alternating(source)
    if kind == "almanac":
        out["prn"] = sv
        out["i"] = I0_REF + float(fields["delta_i"])
    if kind == "special":
        out["message"] = "".join(chr(int(fields[f"char_{k}"])) for k in range(1, 23))
    return out
