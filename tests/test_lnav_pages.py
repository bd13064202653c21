"""LNAV subframes 4 and 5: Table 20-V paging, bit positions from the spec, round trips at scale, real-file pages."""

from __future__ import annotations

import datetime as dt
import math
from pathlib import Path

import numpy as np
import pytest

from scintrack.signals.gps import ephemeris, lnav, lnav_pages
from scintrack.signals.gps.lnav_pages import (
    ALMANAC_FIELDS,
    IONO_UTC_FIELDS,
    NMCT_FIELDS,
    SF4_PAGE25_FIELDS,
    SF5_PAGE25_FIELDS,
    SPECIAL_FIELDS,
    PageData,
    build_page_data,
    page_number,
    page_source_bits,
    read_page,
)

NAV = Path(__file__).resolve().parents[1] / "data" / "ephemerides" / "brdc2800.15n"

# Table 20-V, written out here (not imported): SV ID of subframe 4 pages 1..25.
TABLE_20V_SF4 = [57, 25, 26, 27, 28, 57, 29, 30, 31, 32, 57, 62, 52, 53, 54, 57, 55, 56, 58, 59, 57, 60, 61, 62, 63]


def r(a, b):
    return set(range(a, b + 1))


# Subframe bit numbers of fields per IS-GPS-200 Fig. 20-1 (sheets 4-10), written from the spec's figures.
SPEC_POSITIONS = {
    "almanac": {
        "e": r(69, 84), "t_oa": r(91, 98), "delta_i": r(99, 114), "omega_dot": r(121, 136), "health": r(137, 144),
        "sqrt_a": r(151, 174), "omega0": r(181, 204), "omega": r(211, 234), "m0": r(241, 264),
        "a_f0": r(271, 278) | r(290, 292), "a_f1": r(279, 289),
    },
    "iono_utc": {
        "alpha0": r(69, 76), "alpha1": r(77, 84), "alpha2": r(91, 98), "alpha3": r(99, 106), "beta0": r(107, 114),
        "beta1": r(121, 128), "beta2": r(129, 136), "beta3": r(137, 144), "a1": r(151, 174), "a0": r(181, 204) | r(211, 218),
        "t_ot": r(219, 226), "wn_t": r(227, 234), "dt_ls": r(241, 248), "wn_lsf": r(249, 256), "dn": r(257, 264),
        "dt_lsf": r(271, 278),
    },
    "health_sf5": {
        "t_oa": r(69, 76), "wn_a": r(77, 84), "health_1": r(91, 96), "health_4": r(109, 114), "health_5": r(121, 126),
        "health_13": r(181, 186), "health_24": r(259, 264),
    },
    "config_health_sf4": {
        "config_1": r(69, 72), "config_4": r(81, 84), "config_5": r(91, 94), "config_10": r(111, 114),
        "config_11": r(121, 124), "config_28": r(201, 204), "config_29": r(211, 214), "config_32": r(223, 226),
        "health_25": r(229, 234), "health_26": r(241, 246), "health_29": r(259, 264), "health_30": r(271, 276),
        "health_32": r(283, 288),
    },
    "nmct": {"ai": r(69, 70), "erd_1": r(71, 76), "erd_3": r(83, 84) | r(91, 94), "erd_30": r(287, 292)},
    "special": {"char_1": r(69, 76), "char_2": r(77, 84), "char_3": r(91, 98), "char_22": r(279, 286)},
}
TABLES = {
    "almanac": ALMANAC_FIELDS, "iono_utc": IONO_UTC_FIELDS, "health_sf5": SF5_PAGE25_FIELDS,
    "config_health_sf4": SF4_PAGE25_FIELDS, "nmct": NMCT_FIELDS, "special": SPECIAL_FIELDS,
}


@pytest.fixture(scope="module")
def nav():
    return ephemeris.load(NAV), ephemeris.read_header(NAV)


def decode(t0, pages):
    """Encode the page subframe at t0, check every word's parity, return the decoded page."""
    source, ok = lnav.decode_subframe(lnav.encode_subframe(page_source_bits(t0, pages)))
    assert all(ok)
    return read_page(source, page=page_number(t0))


def t0_of(subframe, page, frame_cycle=0):
    """Start of subframe 4/5 of page ``page`` in the ``frame_cycle``-th 25-frame cycle of the week."""
    return 750 * frame_cycle + 30 * (page - 1) + 6 * (subframe - 1)


def random_pages(rng) -> PageData:
    """PageData whose every field is a random value the message carries exactly."""

    def draw(table):
        out = {}
        for name, f in table.items():
            raw = int(rng.integers(0, 1 << f.bits))
            out[name] = raw if f.scale == 0 and not f.signed else lnav.dequantise(raw, f)
        return out

    almanac = {prn: dict(draw(ALMANAC_FIELDS), t_oa=T_OA) for prn in range(1, 33)}
    return PageData(
        almanac=almanac, t_oa=T_OA, wn_a=int(rng.integers(0, 256)),
        health=tuple(int(v) for v in rng.integers(0, 64, 32)), sv_config=tuple(int(v) for v in rng.integers(0, 16, 32)),
        iono_utc=draw(IONO_UTC_FIELDS), special_message="".join(rng.choice(list("ABCXYZ0189 +-./:'\""), 22)),
        nmct_ai=int(rng.integers(0, 4)),
    )


T_OA = 147 * 4096


def test_field_positions_match_the_spec_figures():
    for kind, spec in SPEC_POSITIONS.items():
        for name, positions in spec.items():
            f = TABLES[kind][name]
            got = {a + k for a, n in f.parts for k in range(n)}
            assert got == positions, (kind, name)
            assert not any(n % 30 in (0, 25, 26, 27, 28, 29) for n in got), (kind, name)  # never on parity bits
    # all 30 ERDs and 22 characters tile their data bits without gaps or overlaps
    erd_bits = [a + k for i in range(1, 31) for a, n in NMCT_FIELDS[f"erd_{i}"].parts for k in range(n)]
    assert len(erd_bits) == len(set(erd_bits)) == 180


def test_page_numbers_and_sv_ids_follow_table_20v(nav):
    pages = build_page_data(*nav)
    assert page_number(0) == 1 and page_number(29.9) == 1 and page_number(30) == 2 and page_number(720) == 25
    assert page_number(750) == 1 and page_number(604770) == 20159 % 25 + 1  # the week restarts paging at page 1
    for cycle in (0, 3):
        for page in range(1, 26):
            sf4, sf5 = decode(t0_of(4, page, cycle), pages), decode(t0_of(5, page, cycle), pages)
            assert sf4["data_id"] == sf5["data_id"] == 0b01
            assert sf4["sv_id"] == TABLE_20V_SF4[page - 1]
            assert sf5["sv_id"] == (page if page <= 24 else 51)
            assert sf4["subframe_id"] == 4 and sf5["subframe_id"] == 5 and sf4["tow17"] * 6 == t0_of(4, page, cycle) + 6
            if page in (2, 3, 4, 5, 7, 8, 9, 10):
                assert sf4["kind"] == "almanac" and sf4["prn"] == sf4["sv_id"]
            assert sf5["kind"] == ("almanac" if page <= 24 else "health_sf5")
    kinds = {p: lnav_pages.page_kind(4, p)[0] for p in range(1, 26)}
    assert kinds[13] == "nmct" and kinds[17] == "special" and kinds[18] == "iono_utc" and kinds[25] == "config_health_sf4"
    assert {p for p, k in kinds.items() if k == "reserved"} == {1, 6, 11, 12, 14, 15, 16, 19, 20, 21, 22, 23, 24}


@pytest.mark.parametrize("seed", range(3))
def test_every_field_of_every_page_round_trips_at_scale(seed):
    pages = random_pages(np.random.default_rng(seed))
    for page in range(1, 26):
        for sf in (4, 5):
            got = decode(t0_of(sf, page, seed), pages)
            kind, sv = lnav_pages.page_kind(sf, page)
            assert got["kind"] == kind
            if kind == "almanac":
                want = pages.almanac[sv]
            elif kind == "health_sf5":
                want = {"t_oa": pages.t_oa, "wn_a": pages.wn_a, **{f"health_{k}": pages.health[k - 1] for k in range(1, 25)}}
            elif kind == "config_health_sf4":
                want = {f"config_{k}": pages.sv_config[k - 1] for k in range(1, 33)}
                want.update({f"health_{k}": pages.health[k - 1] for k in range(25, 33)})
            elif kind == "iono_utc":
                want = pages.iono_utc
            elif kind == "nmct":
                want = {"ai": pages.nmct_ai, **{f"erd_{k}": 0b100000 for k in range(1, 31)}}
            elif kind == "special":
                want = {"message": pages.special_message}
            else:
                want = {"filler_ok": True}
            for name, value in want.items():
                assert got[name] == value, (sf, page, name)


def test_almanac_is_each_prn_propagated_to_t_oa_at_almanac_precision(nav):
    eph, header = nav
    pages = build_page_data(eph, header)
    week_a, t_oa = lnav_pages.default_almanac_epoch(eph)
    assert t_oa % 4096 == 0 and pages.wn_a == week_a % 256
    toes = [e.week * 604800 + e.t_oe for e in eph]
    assert abs(week_a * 604800 + t_oa - (min(toes) + max(toes)) / 2) <= 2048
    groups = ephemeris.by_prn(eph)
    for prn in range(1, 33):
        sets = groups[prn]
        e = min(sets, key=lambda s: abs(s.week * 604800 + s.t_oe - week_a * 604800 - t_oa))
        f = e.fields
        d = (week_a * 604800 + t_oa) - (e.week * 604800 + e.t_oe)
        n_sc = math.sqrt(3.986005e14 / f["sqrt_a"] ** 6) / 3.1415926535898 + f["delta_n"]  # semicircles/s
        want = {
            "e": f["e"], "sqrt_a": f["sqrt_a"], "omega": f["omega"], "omega_dot": f["omega_dot"],
            "delta_i": f["i0"] + f["idot"] * d - 0.30,
            "m0": (f["m0"] + n_sc * d + 1) % 2 - 1, "omega0": (f["omega0"] + f["omega_dot"] * d + 1) % 2 - 1,
            "a_f0": f["a_f0"] + f["a_f1"] * d + f["a_f2"] * d * d, "a_f1": f["a_f1"] + 2 * f["a_f2"] * d,
        }
        page = prn if prn <= 24 else {25: 2, 26: 3, 27: 4, 28: 5, 29: 7, 30: 8, 31: 9, 32: 10}[prn]
        got = decode(t0_of(5 if prn <= 24 else 4, page), pages)
        assert got["sv_id"] == prn and got["t_oa"] == t_oa
        for name, value in want.items():
            half_lsb = 2.0 ** (ALMANAC_FIELDS[name].scale - 1)
            err = got[name] - value
            if name in ("m0", "omega0"):
                err = (err + 1) % 2 - 1
            assert abs(err) <= half_lsb * (1 + 1e-9), (prn, name, err / half_lsb)
        h = int(f["health"])
        assert got["health"] == (0 if h == 0 else (0b11100000 if h >= 32 else 0) | (h & 31))
    sf5_25, sf4_25 = decode(t0_of(5, 25), pages), decode(t0_of(4, 25), pages)
    assert sf5_25["health_10"] == 63 and decode(t0_of(5, 10), pages)["health"] == 255  # PRN 10 is flagged unusable in the file
    assert all(sf5_25[f"health_{k}"] == 0 for k in range(1, 25) if k != 10)
    assert all(sf4_25[f"config_{k}"] == 0b1001 for k in range(1, 33))


def test_prns_absent_from_the_file_are_dummy_svs(nav):
    eph, header = nav
    pages = build_page_data([e for e in eph if e.prn not in (5, 27)], header)
    for sf, page in ((5, 5), (4, 4)):  # PRN 5 and PRN 27 almanac slots
        sent = lnav.encode_subframe(page_source_bits(t0_of(sf, page), pages))
        source, ok = lnav.decode_subframe(sent)
        assert all(ok)  # valid parity
        got = read_page(source)
        assert got["sv_id"] == 0 and got["kind"] == "dummy" and got["filler_ok"]
        for w in range(3, 10):  # words 4-9 are entirely 1010...
            assert source[30 * w : 30 * w + 24] == [1, 0] * 12
    sf5_25, sf4_25 = decode(t0_of(5, 25), pages), decode(t0_of(4, 25), pages)
    assert sf5_25["health_5"] == 0b111111 and sf4_25["health_27"] == 0b111111
    assert sf4_25["config_5"] == sf4_25["config_27"] == 0 and sf4_25["config_6"] == 0b1001
    assert decode(t0_of(5, 6), pages)["sv_id"] == 6


def test_iono_utc_page_carries_the_rinex_header(nav):
    eph, header = nav
    got = decode(t0_of(4, 18), build_page_data(eph, header))
    assert got["sv_id"] == 56
    for k in range(4):
        assert abs(got[f"alpha{k}"] - header.alpha[k]) <= 2.0 ** (IONO_UTC_FIELDS[f"alpha{k}"].scale - 1)
        assert abs(got[f"beta{k}"] - header.beta[k]) <= 2.0 ** (IONO_UTC_FIELDS[f"beta{k}"].scale - 1)
    assert abs(got["a0"] - header.a0) <= 2.0**-31 and abs(got["a1"] - header.a1) <= 2.0**-51
    assert got["t_ot"] == header.t_ot == 405504 and got["wn_t"] == 1865 % 256
    last_leap_day = dt.date(2015, 6, 30)  # GPS-UTC became 17 s after this day
    days = (last_leap_day - dt.date(1980, 1, 6)).days
    assert got["dt_ls"] == got["dt_lsf"] == header.leap_seconds == 17
    assert got["wn_lsf"] == (days // 7) % 256 and got["dn"] == last_leap_day.isoweekday() % 7 + 1  # DN 1 = Sunday
    assert got["alpha0"] == 16 * 2.0**-30 and got["beta0"] == 52 * 2.0**11  # header 0.1490D-07, 0.1065D+06


def test_nmct_special_message_and_reserved_fillers(nav):
    eph, header = nav
    pages = build_page_data(eph, header, special_message="SCINTRACK SIM 1.0")
    nmct = decode(t0_of(4, 13), pages)
    assert nmct["ai"] == 0b10 and all(nmct[f"erd_{k}"] == 0b100000 for k in range(1, 31))
    assert decode(t0_of(4, 17), pages)["message"] == "SCINTRACK SIM 1.0".ljust(22)
    for page in (1, 6, 11, 12, 14, 15, 16, 19, 20, 21, 22, 23, 24):
        got = decode(t0_of(4, page), pages)
        assert got["kind"] == "reserved" and got["filler_ok"]
    source = page_source_bits(t0_of(4, 19), pages)
    source[150] ^= 1
    assert not read_page(source)["filler_ok"]


def test_bad_inputs_are_refused(nav):
    eph, header = nav
    with pytest.raises(ValueError, match="special_message"):
        build_page_data(eph, header, special_message="lower case")
    with pytest.raises(ValueError, match="t_oa"):
        build_page_data(eph, header, almanac_epoch=(1865, 1000))
    with pytest.raises(ValueError, match="pages are subframes 4 and 5"):
        page_source_bits(6, build_page_data(eph, header))
    with pytest.raises(ValueError, match="t_ot"):
        build_page_data(eph, ephemeris.NavHeader(header.alpha, header.beta, header.a0, header.a1, 405500, 1865, 17))
    with pytest.raises(ValueError, match="sv_config"):
        build_page_data(eph, header, sv_config={33: 9})
