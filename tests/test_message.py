"""The LNAV stream with data-set scheduling: parity over long streams, cutovers, uploads, re-referencing, decoding."""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path

import numpy as np
import pytest

from scintrack.signals.gps import ephemeris, lnav, lnav_pages
from scintrack.signals.gps.message import Schedule, Upload, build_message, decode_message, rereference

NAV = Path(__file__).resolve().parents[1] / "data" / "ephemerides" / "brdc2800.15n"
WEEK = 1865
DAY = 3 * 86400  # 2015-10-07 is Wednesday of GPS week 1865
H = 3600

# ---- independent references, written from the spec, not from the code under test -------------------------

# IS-GPS-200 Table 20-XIV: (previous-word bit, d_i list) for D25..D30.
PARITY_EQUATIONS = (
    (29, [1, 2, 3, 5, 6, 10, 11, 12, 13, 14, 17, 18, 20, 23]),
    (30, [2, 3, 4, 6, 7, 11, 12, 13, 14, 15, 18, 19, 21, 24]),
    (29, [1, 3, 4, 5, 7, 8, 12, 13, 14, 15, 16, 19, 20, 22]),
    (30, [2, 4, 5, 6, 8, 9, 13, 14, 15, 16, 17, 20, 21, 23]),
    (30, [1, 3, 5, 6, 7, 9, 10, 14, 15, 16, 17, 18, 21, 22, 24]),
    (29, [3, 5, 6, 8, 9, 10, 11, 13, 15, 19, 22, 23, 24]),
)


def parity_verdicts(bits: np.ndarray) -> np.ndarray:
    """Per-word parity check of a word-aligned stream that starts after a word ending in D29 = D30 = 0."""
    w = bits.reshape(-1, 30).astype(int)
    prev29 = np.concatenate(([0], w[:-1, 28]))
    prev30 = np.concatenate(([0], w[:-1, 29]))
    d = w[:, :24] ^ prev30[:, None]  # d_i = D_i xor D30*
    ok = np.ones(len(w), dtype=bool)
    for k, (which, taps) in enumerate(PARITY_EQUATIONS):
        p = (prev29 if which == 29 else prev30) + d[:, [i - 1 for i in taps]].sum(axis=1)
        ok &= (p % 2) == w[:, 24 + k]
    return ok


MU, OMEGA_E, PI = 3.986005e14, 7.2921151467e-5, 3.1415926535898


def kepler_position(f: dict, t: float) -> np.ndarray:
    """ECEF position (m) at time of week t from LNAV fields in semicircles (IS-GPS-200 Table 20-IV)."""
    a = f["sqrt_a"] ** 2
    n = math.sqrt(MU / a**3) + f["delta_n"] * PI
    tk = t - f["t_oe"]
    tk -= 604800 * round(tk / 604800)
    m = f["m0"] * PI + n * tk
    e_anom = m
    for _ in range(30):
        e_anom = m + f["e"] * math.sin(e_anom)
    nu = math.atan2(math.sqrt(1 - f["e"] ** 2) * math.sin(e_anom), math.cos(e_anom) - f["e"])
    phi = nu + f["omega"] * PI
    s2, c2 = math.sin(2 * phi), math.cos(2 * phi)
    u = phi + f["c_us"] * s2 + f["c_uc"] * c2
    r = a * (1 - f["e"] * math.cos(e_anom)) + f["c_rs"] * s2 + f["c_rc"] * c2
    i = f["i0"] * PI + f["c_is"] * s2 + f["c_ic"] * c2 + f["idot"] * PI * tk
    om = f["omega0"] * PI + (f["omega_dot"] * PI - OMEGA_E) * tk - OMEGA_E * f["t_oe"]
    x, y = r * math.cos(u), r * math.sin(u)
    return np.array([x * math.cos(om) - y * math.cos(i) * math.sin(om), x * math.sin(om) + y * math.cos(i) * math.cos(om), y * math.sin(i)])


def clock(f: dict, t: float) -> float:
    dt = t - f["t_oc"]
    return f["a_f0"] + f["a_f1"] * dt + f["a_f2"] * dt * dt


def almanac_as_ephemeris(a: dict) -> dict:
    """Table 20-VI/20-IV almanac model: no delta_n, no harmonics, i = 0.30 + delta_i, t_oe = t_oa."""
    zero = dict.fromkeys(("delta_n", "c_us", "c_uc", "c_rs", "c_rc", "c_is", "c_ic", "idot"), 0.0)
    return {**zero, **{k: a[k] for k in ("sqrt_a", "e", "m0", "omega", "omega0", "omega_dot")}, "i0": 0.30 + a["delta_i"], "t_oe": a["t_oa"]}


# ---- fixtures and helpers ----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def nav():
    eph = ephemeris.load(NAV)
    header = ephemeris.read_header(NAV)
    return eph, header, lnav_pages.build_page_data(eph, header)


def frames(decoded):
    """Decoded subframes grouped by frame start time."""
    out: dict[int, dict[int, object]] = {}
    for s in decoded:
        out.setdefault(s.t0 - (s.subframe_id - 1) * 6, {})[s.subframe_id] = s
    return out


def iode_copies(frame) -> tuple[int, int, int]:
    return int(frame[1].fields["iodc"]) % 256, int(frame[2].fields["iode"]), int(frame[3].fields["iode"])


def eph_fields(frame) -> dict:
    return {**frame[1].fields, **frame[2].fields, **frame[3].fields}


def file_set(eph, prn, t_oe):
    return next(e for e in eph if e.prn == prn and e.t_oe == t_oe)


def slot_set(eph, prn, slot_end):
    """The file's set for the 2-h slot ending at slot_end: t_oe = slot_end, else the latest t_oe inside the slot."""
    inside = [e for e in eph if e.prn == prn and slot_end - 2 * H < e.t_oe <= slot_end]
    exact = [e for e in inside if e.t_oe == slot_end]
    return (exact or sorted(inside, key=lambda e: e.t_oe))[-1]


# ---- tests -------------------------------------------------------------------------------------------------


def test_every_word_of_a_full_page_cycle_passes_the_spec_parity_and_decodes(nav):
    eph, header, pages = nav
    t_start = DAY + 10 * H + 15
    msg = build_message(eph, header, 1, WEEK, t_start, t_start + 750 - 30, [Upload(1, DAY + 10 * H + 200)], pages=pages)
    assert msg.t0 == DAY + 10 * H and len(msg.bits) == 25 * 1500  # 25 frames = the whole page cycle
    ok = parity_verdicts(msg.bits)
    assert ok.all() and len(ok) == 1250
    words = msg.bits.reshape(-1, 30)
    assert (words[1::10, 28:] == 0).all() and (words[9::10, 28:] == 0).all()  # HOW and word 10 end in D29 = D30 = 0
    inverted = np.concatenate(([0], words[:-1, 29])) == 1
    src = msg.source.reshape(-1, 30)
    assert inverted.sum() > 100
    assert (src[:, :24] == (words[:, :24] ^ inverted[:, None])).all() and (src[:, 24:] == words[:, 24:]).all()
    bad = msg.bits.copy()
    bad[5 * 30 + 7] ^= 1
    assert parity_verdicts(bad).sum() == 1249  # the check sees a single flipped bit

    decoded = decode_message(msg.bits)
    assert len(decoded) == 125 and all(s.ok for s in decoded) and not decoded[0].inverted
    assert [s.t0 for s in decoded] == msg.subframe_t0.tolist()
    assert [s.subframe_id for s in decoded] == msg.subframe_id.tolist() == [1, 2, 3, 4, 5] * 25
    for s, page, sv in zip(decoded, msg.page, msg.sv_id):
        assert s.fields["preamble"] == 0b10001011
        assert s.fields["tow17"] == (s.t0 + 6) // 6  # HOW TOW = start of the next subframe
        if s.subframe_id >= 4:
            assert page == (s.t0 // 30) % 25 + 1 == s.fields["page"] and sv == s.fields["sv_id"]
    assert sorted(set(msg.page.tolist()) - {-1}) == list(range(1, 26))
    assert msg.page[msg.subframe_id < 4].tolist() == [-1] * 75


def test_subframes_1_to_3_carry_the_data_set_in_force_at_scale(nav):
    eph, header, pages = nav
    msg = build_message(eph, header, 11, WEEK, DAY + 13 * H + 40, DAY + 13 * H + 100, pages=pages)
    want = file_set(eph, 11, DAY + 14 * H).fields  # even-hour set t_oe = 14:00 is sent during [12:00, 14:00)
    for f in frames(decode_message(msg.bits)).values():
        got = eph_fields(f)
        for sf in (1, 2, 3):
            for name, field in lnav.FIELDS[sf].items():
                expected = WEEK % 1024 if name == "wn" else want[name]  # WN = week of transmission
                assert abs(got[name] - expected) <= (0 if field.scale == 0 and not field.signed else 2.0 ** (field.scale - 1)), name
    # subframes 4/5 carry the shared pages: the almanac of the decoded page equals the PageData almanac at scale
    sf5 = next(s for s in decode_message(msg.bits) if s.subframe_id == 5)
    alm = pages.almanac[sf5.fields["sv_id"]]
    assert all(abs(sf5.fields[k] - alm[k]) <= 2.0 ** (f.scale - 1) for k, f in lnav_pages.ALMANAC_FIELDS.items() if f.scale < 0)


def test_even_hour_cutover_changes_all_three_iode_copies_at_the_frame_boundary(nav):
    eph, header, pages = nav
    for prn in (1, 11, 28, 30):
        msg = build_message(eph, header, prn, WEEK, DAY + 10 * H - 90, DAY + 10 * H + 90, pages=pages)
        old, new = slot_set(eph, prn, DAY + 10 * H), slot_set(eph, prn, DAY + 12 * H)
        assert old.iode != new.iode
        by_frame = frames(decode_message(msg.bits))
        for t_frame, f in by_frame.items():
            expected = old if t_frame < DAY + 10 * H else new
            assert iode_copies(f) == (expected.iode,) * 3, (prn, t_frame)
            assert f[1].fields["t_oc"] == f[2].fields["t_oe"] == expected.t_oe
        first_new = by_frame[DAY + 10 * H][1]  # subframe 1 right after the hour boundary
        assert first_new.fields["iodc"] == new.iodc and abs(first_new.fields["a_f0"] - new.fields["a_f0"]) <= 2.0**-32
        assert set(msg.dataset_kind.tolist()) == {"regular"}
        assert msg.iode[msg.subframe_t0 < DAY + 10 * H].tolist().count(old.iode) == 9  # 3 frames x 3 copies


def test_upload_cuts_in_at_the_next_frame_with_an_unused_iode_and_a_new_t_oe(nav):
    eph, header, pages = nav
    prn, t_up = 30, DAY + 10 * H + 31 * 60 + 7  # 10:31:07 -> cut-in at 10:31:30
    t_cut, slot_end = DAY + 10 * H + 31 * 60 + 30, DAY + 12 * H
    msg = build_message(eph, header, prn, WEEK, t_cut - 60, slot_end + 60, [Upload(prn, t_up)], pages=pages)
    by_frame = frames(decode_message(msg.bits))
    assert all(s.ok for f in by_frame.values() for s in f.values())
    regular_now, regular_next = slot_set(eph, prn, DAY + 12 * H), slot_set(eph, prn, DAY + 14 * H)
    up = by_frame[t_cut]
    iode = iode_copies(up)[0]
    assert len(set(iode_copies(up))) == 1
    for t_frame, f in by_frame.items():
        if t_frame < t_cut:
            assert iode_copies(f) == (regular_now.iode,) * 3
        elif t_frame < slot_end:
            assert iode_copies(f) == (iode,) * 3 and f[2].fields["t_oe"] == slot_end - 16  # hh:59:44
        else:  # after the upload's slot the regular sequence resumes
            assert iode_copies(f) == (regular_next.iode,) * 3
    assert up[2].fields["t_oe"] == up[1].fields["t_oc"] == DAY + 12 * H - 16 != regular_now.t_oe
    # out of sequence: not an IODE this PRN used within 6 h before (or 8 h after) the cut-in, IODC never used in the file
    nearby = {e.iode for e in eph if e.prn == prn and t_cut - 6 * H <= e.t_oe <= t_cut + 8 * H}
    assert iode not in nearby and {regular_now.iode, regular_next.iode} <= nearby
    assert up[1].fields["iodc"] not in {e.iodc for e in eph if e.prn == prn} and up[1].fields["iodc"] % 256 == iode
    sched = Schedule(eph, prn, WEEK, [Upload(prn, t_up)])
    transmitted_before = {sched.at(WEEK * 604800 + t).iode for t in range(t_cut - 6 * H, t_cut, 30)}
    assert iode not in transmitted_before
    kinds = msg.dataset_kind[(msg.subframe_t0 >= t_cut) & (msg.subframe_t0 < slot_end)]
    assert set(kinds.tolist()) == {"upload"} and set(msg.dataset_kind[msg.subframe_t0 < t_cut].tolist()) == {"regular"}


def test_upload_iode_skips_recent_iodes_but_may_reuse_older_ones(nav):
    eph, header, pages = nav
    prn, t_cut = 30, DAY + 10 * H + 31 * 60 + 30
    relabelled, far, near = [], 0, 0
    for e in sorted((e for e in eph if e.prn == prn), key=lambda e: e.t_oe):
        if t_cut - 6 * H <= e.t_oe <= t_cut + 8 * H:  # sent within 6 h of the cut-in: IODE 0, 1, ..., IODC MSBs 2 or 3
            iode, iodc, near = near, 256 * (2 + near % 2) + near, near + 1
        else:  # sent more than 6 h away: their IODEs (8 for 04:00, 9 for 02:00, ...) may be reused, IODC (MSBs 0) may not
            iode = iodc = 8 + round(abs(e.t_oe - (t_cut - 6 * H)) / (2 * H))
            far += 1
        relabelled.append(dataclasses.replace(e, fields=dict(e.fields, iode=iode, iodc=iodc)))
    msg = build_message(relabelled, header, prn, WEEK, t_cut, t_cut + 30, [Upload(prn, t_cut - 10)], pages=pages)
    current = slot_set(relabelled, prn, DAY + 12 * H)
    assert near == 8 and far == 5  # 06:00 .. 18:00 (with two hh:59:44 sets) are near, 00:00-04:00 and 20:00-22:00 far
    assert slot_set(relabelled, prn, DAY + 4 * H).iode == 8
    assert msg.iode[0] == 8  # the smallest IODE not sent within 6 h: that of the 04:00 set, last sent 6.5 h before
    assert msg.iodc[0] == (current.iodc >> 8) * 256 + 8  # keeps the IODC MSBs of the set in force


def test_uploaded_set_describes_the_same_orbit_and_clock_as_the_regular_one(nav):
    eph, header, pages = nav
    half_lsb_m = 0.5 * 2.0**-31 * PI * 26.6e6  # 2 cm: rounding of M0', OMEGA0', i0' to 2^-31 sc at GPS radius
    for prn in (1, 11, 28, 30):
        t_cut = DAY + 10 * H + 30 * 60
        msg = build_message(eph, header, prn, WEEK, t_cut - 30, t_cut + 30, [Upload(prn, t_cut)], pages=pages)
        by_frame = frames(decode_message(msg.bits))
        reg, upl = eph_fields(by_frame[t_cut - 30]), eph_fields(by_frame[t_cut])
        assert upl["t_oe"] == reg["t_oe"] - 16 and upl["iode"] != reg["iode"]
        for t in np.linspace(t_cut - 2 * H, DAY + 14 * H, 17):  # the whole 4-h fit interval of the regular set
            dp = np.linalg.norm(kepler_position(upl, t) - kepler_position(reg, t))
            assert dp <= 3 * half_lsb_m * 1.05, (prn, t, dp)
            assert abs(clock(upl, t) - clock(reg, t)) <= 2.0**-32 + 1e-15, prn  # half an a_f0 LSB
    # large shifts and a non-zero a_f2 (exact relations, before rounding)
    f = dict(file_set(eph, 28, DAY + 12 * H).fields, a_f2=3.0e-18)
    g = rereference(f, -2 * H - 16)
    assert g["t_oc"] == g["t_oe"] == DAY + 10 * H - 16
    for t in (DAY + 9 * H, DAY + 11 * H, DAY + 13 * H):
        assert np.linalg.norm(kepler_position(g, t) - kepler_position(f, t)) < 1e-5 and abs(clock(g, t) - clock(f, t)) < 1e-18


def test_repeated_uploads_get_distinct_t_oe_and_iode(nav):
    eph, header, pages = nav
    prn, t1, t2 = 1, DAY + 10 * H + 5 * 60, DAY + 10 * H + 20 * 60
    msg = build_message(eph, header, prn, WEEK, t1, t2 + 60, [Upload(prn, t2), Upload(prn, t1), Upload(11, t1)], pages=pages)
    f = frames(decode_message(msg.bits))
    first, second = eph_fields(f[t1]), eph_fields(f[t2])
    assert first["t_oe"] == DAY + 12 * H - 16 and second["t_oe"] == DAY + 12 * H - 32  # differs from the set in force
    assert len({first["iode"], second["iode"], file_set(eph, prn, DAY + 12 * H).iode}) == 3
    assert all(k == "upload" for k in msg.dataset_kind)


def test_almanac_from_the_same_ephemerides_is_within_almanac_accuracy(nav):
    eph, header, pages = nav
    for prn in (1, 11, 28, 30):
        e = min((s for s in eph if s.prn == prn), key=lambda s: abs(s.t_oe - pages.t_oa))
        alm = almanac_as_ephemeris(pages.almanac[prn])
        for t in (pages.t_oa - H, pages.t_oa, pages.t_oa + H):
            assert np.linalg.norm(kepler_position(alm, t) - kepler_position(e.fields, t)) < 5e3  # almanac: km level


def test_stream_spans_whole_frames_is_deterministic_and_resynchronises(nav):
    eph, header, pages = nav
    t_start, t_end = DAY + 11 * H + 100.5, DAY + 11 * H + 161
    msg = build_message(eph, header, 28, WEEK, t_start, t_end, pages=pages)
    assert msg.t0 == DAY + 11 * H + 90 and msg.t_end == DAY + 11 * H + 180 and msg.bits.dtype == np.int8
    again = build_message(eph, header, 28, WEEK, t_start, t_end)
    assert np.array_equal(msg.bits, again.bits) and np.array_equal(msg.source, again.source)
    longer = build_message(eph, header, 28, WEEK, DAY + 11 * H, DAY + 11 * H + 300, pages=pages)
    assert np.array_equal(longer.bits[90 * 50 : 180 * 50], msg.bits)  # chaining restarts cleanly at frame boundaries
    clean = decode_message(longer.bits)
    shifted = decode_message(1 - longer.bits[137:])  # receiver starts mid-word with the 180-degree ambiguity
    assert all(s.inverted and s.ok for s in shifted) and len(shifted) == len(clean) - 1
    assert [(s.t0, dict(s.fields)) for s in shifted] == [(s.t0, dict(s.fields)) for s in clean[1:]]


def test_how_tow_wraps_at_the_end_of_the_week(nav):
    eph, header, pages = nav
    shift = 3 * 86400  # PRN 1's 22:00 Wednesday set moved to 22:00 Saturday, the last slot of the week
    moved = [
        ephemeris.Ephemeris(e.prn, e.week, e.transmit_time + shift, e.fit_hours, dict(e.fields, t_oe=e.t_oe + shift, t_oc=e.t_oc + shift))
        for e in eph if e.prn == 1 and e.t_oe == DAY + 22 * H
    ]
    msg = build_message(moved, header, 1, WEEK, 604740, 604800, pages=pages)
    decoded = decode_message(msg.bits)
    assert [s.t0 for s in decoded][-1] == 604794 and decoded[-1].fields["tow17"] == 0 and all(s.ok for s in decoded)
    assert eph_fields(frames(decoded)[604770])["t_oe"] == 604800 - 2 * H  # no set for the next week's 0 h: previous one stays


def test_five_minutes_for_four_prns_is_fast(nav):
    eph, header, _ = nav
    start = time.perf_counter()
    for prn in (1, 11, 28, 30):
        build_message(eph, header, prn, WEEK, DAY + 10.5 * H, DAY + 10.5 * H + 300)
    assert time.perf_counter() - start < 2.0


def test_bad_inputs_are_refused(nav):
    eph, header, pages = nav
    with pytest.raises(ValueError, match="prn"):
        Upload(0, 100.0)
    with pytest.raises(ValueError, match="time_s"):
        Upload(1, -5.0)
    with pytest.raises(ValueError, match="t_start"):
        build_message(eph, header, 1, WEEK, DAY + 100, DAY + 100, pages=pages)
    with pytest.raises(ValueError, match="no data set for PRN 7"):
        build_message([e for e in eph if e.prn != 7], header, 7, WEEK, DAY, DAY + 30, pages=pages)
    with pytest.raises(ValueError, match="PRN 1 has no data set"):
        build_message(eph, header, 1, WEEK, 100, 200, pages=pages)  # Sunday: outside the file
