"""Bit prediction for the MM filter: upload-robust mask (recounted independently), IODE check, priors, Fig. 4 map."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scintrack.signals.gps import bit_prediction as bp
from scintrack.signals.gps import ephemeris, lnav, lnav_pages
from scintrack.signals.gps.message import Schedule, Upload, build_message

NAV = Path(__file__).resolve().parents[1] / "data" / "ephemerides" / "brdc2800.15n"
WEEK = 1865
DAY = 3 * 86400  # 2015-10-07 is Wednesday of GPS week 1865
T = DAY + 10 * 3600 + 27 * 60  # 10:27 GPS time, the scenario start
PRNS = (1, 11, 28, 30)
EPS = 1e-3

# ---- independent encoder, written from IS-GPS-200 Table 20-XIV (not the module's or lnav's code) -------------

PARITY_EQUATIONS = (
    (29, [1, 2, 3, 5, 6, 10, 11, 12, 13, 14, 17, 18, 20, 23]),
    (30, [2, 3, 4, 6, 7, 11, 12, 13, 14, 15, 18, 19, 21, 24]),
    (29, [1, 3, 4, 5, 7, 8, 12, 13, 14, 15, 16, 19, 20, 22]),
    (30, [2, 4, 5, 6, 8, 9, 13, 14, 15, 16, 17, 20, 21, 23]),
    (30, [1, 3, 5, 6, 7, 9, 10, 14, 15, 16, 17, 18, 21, 22, 24]),
    (29, [3, 5, 6, 8, 9, 10, 11, 13, 15, 19, 22, 23, 24]),
)


def spec_word(d: list[int], p29: int, p30: int) -> list[int]:
    """D1..D30 of data d1..d24 (list index 0 = d1) after a word ending in (p29, p30)."""
    prev = {29: p29, 30: p30}
    par = [(prev[w] + sum(d[i - 1] for i in taps)) % 2 for w, taps in PARITY_EQUATIONS]
    return [b ^ p30 for b in d] + par


def spec_subframe(source: list[int]) -> list[int]:
    """Transmitted subframe from source bits; words 2 and 10 get d23, d24 making D29 = D30 = 0 (searched)."""
    out, p29, p30 = [], 0, 0
    for w in range(10):
        d = list(source[30 * w : 30 * w + 24])
        if w in (1, 9):
            d[22:] = next([a, b] for a in (0, 1) for b in (0, 1) if spec_word(d[:22] + [a, b], p29, p30)[28:] == [0, 0])
        word = spec_word(d, p29, p30)
        out += word
        p29, p30 = word[28], word[29]
    return out


# ---- fixtures ----------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def nav():
    eph = ephemeris.load(NAV)
    header = ephemeris.read_header(NAV)
    return eph, header, lnav_pages.build_page_data(eph, header)


@pytest.fixture(scope="module")
def robust(nav):
    """Upload-robust prediction of PRN 1 and 11 over one 25-page cycle from 10:27."""
    eph, header, pages = nav
    return {prn: bp.robust_prediction(eph, header, prn, WEEK, T, T + 750, pages=pages) for prn in (1, 11)}


def frames_of(bits: np.ndarray) -> np.ndarray:
    return np.asarray(bits).reshape(-1, 1500)


# ---- strategy (b): the mask --------------------------------------------------------------------------------


def test_stream_encoder_is_build_message(nav, robust):
    eph, header, pages = nav
    assert np.array_equal(robust[1].bits, build_message(eph, header, 1, WEEK, T, T + 750, pages=pages).bits)
    with_upload = Schedule(eph, 11, WEEK, [Upload(11, T + 95)])
    fields = [with_upload.at(WEEK * 604800 + T + 30 * j).fields for j in range(6)]
    want = build_message(eph, header, 11, WEEK, T, T + 180, [Upload(11, T + 95)], pages=pages).bits
    assert np.array_equal(bp.encode_stream(fields, pages, WEEK, T), want)


def test_mask_marks_preamble_and_how_tow_predictable_and_sf2_iode_not(robust):
    preamble = [1, 0, 0, 0, 1, 0, 1, 1]
    for r in robust.values():
        sub = r.mask.reshape(-1, 300)
        bits = r.bits.reshape(-1, 300)
        assert len(sub) == 125 and r.t0 == T
        assert sub[:, 0:8].all() and (bits[:, 0:8] == preamble).all()  # preamble: word 1 is never inverted
        assert sub[:, 30:47].all()  # HOW TOW, 17 bits, every subframe
        assert sub[:, 49:52].all()  # subframe ID
        assert not sub[1::5, 60:68].any()  # SF2 IODE, every frame
        assert not sub[2::5, 270:278].any() and not sub[0::5, 210:218].any()  # the other two copies
        assert sub[3::5].all() and sub[4::5].all()  # pages known: every SF4/5 bit
        # TOW values are those of time: HOW word 2, bits 31-47 (never inverted: TLM ends in D30 = 0 here)
        tow = [int("".join(map(str, b[30:47])), 2) for b in bits]
        assert tow == [(T + 6 * k + 6) // 6 for k in range(125)]


def test_mask_matches_an_independent_recount_and_fraction_bounds(nav, robust):
    eph, header, pages = nav
    prn = 11
    r = robust[prn]
    # alternatives rebuilt differently: uploads through build_message, file sets through the spec encoder above
    streams = [frames_of(build_message(eph, header, prn, WEEK, T, T + 750, [Upload(prn, T + 30 * j)], pages=pages).bits) for j in range(25)]
    truth = frames_of(build_message(eph, header, prn, WEEK, T, T + 750, pages=pages).bits)
    sets = [e.fields for e in eph if e.prn == prn]
    for j in range(25):  # every upload with its IODE label complemented (IODC MSBs kept)
        ds = Schedule(eph, prn, WEEK, [Upload(prn, T + 30 * j)]).at(WEEK * 604800 + T + 30 * j)
        iode = 255 - ds.iode
        sets.append({**ds.fields, "iode": iode, "iodc": ds.iodc - ds.iodc % 256 + iode})
    recount = np.ones((25, 1500), dtype=bool)
    for j in range(25):
        for s in streams:
            recount[j] &= s[j] == truth[j]
        for fields in sets:
            for k in range(3):
                t0 = T + 30 * j + 6 * k
                alt = spec_subframe(lnav.source_bits(t0, {**fields, "wn": WEEK % 1024}))
                recount[j, 300 * k : 300 * (k + 1)] &= np.array(alt) == truth[j, 300 * k : 300 * (k + 1)]
    assert np.array_equal(recount.reshape(-1), r.mask)
    assert r.mask.mean() == pytest.approx(recount.mean(), abs=0)
    assert bp.predictable_fraction(eph, header, prn, WEEK, T, pages=pages) == recount.mean()
    # floor: TLM + HOW of all five subframes + all SF4/5 are always in; SF2/3 words 4-9 never (polarity chain)
    assert recount.mean() >= (5 * 60 + 2 * 240) / 1500
    m = recount.reshape(25, 5, 10, 30)
    assert not m[:, 1:3, 3:9].any()


def test_almanac_update_pages_bring_the_fraction_to_the_papers_range(nav):
    eph, header, pages = nav
    alternatives = bp.almanac_update_pages(eph, header)
    assert len(alternatives) >= 2 and all(p.t_oa != pages.t_oa for p in alternatives)
    for prn in PRNS:
        known = bp.robust_prediction(eph, header, prn, WEEK, T, T + 750, pages=pages)
        update = bp.robust_prediction(eph, header, prn, WEEK, T, T + 750, pages=pages, page_alternatives=alternatives)
        k, u = known.mask.reshape(25, 5, 300), update.mask.reshape(25, 5, 300)
        assert np.array_equal(k[:, :3], u[:, :3]) and k[:, 3:].all()  # page alternatives touch SF4/5 only
        assert 0.25 <= u.mean() <= 0.60, (prn, u.mean())
        assert u[:, 3:, :60].all() and u[:, 3:, 60:68].all()  # TLM, HOW, data ID and SV ID survive an almanac update
        assert not u[:, 4, 60:].all() and not u[:, 3, 60:].all()  # almanac content changes with the update


# ---- strategy (c): the IODE check --------------------------------------------------------------------------


def history_and_scenario(nav, prn, uploads=()):
    """25 clean frames before T (decided = true bits) and the scenario's 8 frames (4 min) with ``uploads``."""
    eph, header, pages = nav
    hist = frames_of(build_message(eph, header, prn, WEEK, T - 750, T - 1, pages=pages).bits)
    scen = frames_of(build_message(eph, header, prn, WEEK, T, T + 240, list(uploads), pages=pages).bits)
    return hist, scen


def test_iode_check_predicts_the_next_frame_bit_exactly(nav):
    hist, scen = history_and_scenario(nav, 28)
    stored = np.stack([bp.decode_frame(f)[0] for f in hist])
    assert all(bp.decode_frame(f)[1].all() for f in hist)  # true bits: every word passes parity
    pred = bp.predict_next_frame(stored, T)
    assert np.array_equal(pred, scen[0])
    assert (bp.predict_next_frame(stored[-24:], T)[900:] == -1).all()  # no 12.5-min history: no pages
    # a decision error outside the IODE copies: predicted with one stored frame, outvoted with three
    noisy = stored.copy()
    flipped_hist = hist[-1].copy()
    flipped_hist[300 + 4 * 30 + 5] ^= 1  # SF2 word 5 (M0 LSBs)
    noisy[-1] = bp.decode_frame(flipped_hist)[0]
    assert (bp.predict_next_frame(noisy, T, content_frames=1) != scen[0]).sum() >= 1
    assert np.array_equal(bp.predict_next_frame(noisy, T, content_frames=3), scen[0])

    r = bp.robust_prediction(nav[0], nav[1], 28, WEEK, T, T + 240, pages=nav[2])
    p = bp.BitPredictor("iode", r, history=hist, eps=EPS)
    for k in range(len(scen)):
        assert p.mode(k) == "iode"
        assert np.array_equal(p.priors(k), np.where(scen[k] == 0, 1 - EPS, EPS))  # 100 %, all right
        p.observe(scen[k])


def test_fork_is_independent_of_its_parent(nav):
    """A fork observes frames without changing its parent, and predicts what a fresh predictor fed the same frames does."""
    hist, scen = history_and_scenario(nav, 28)
    r = bp.robust_prediction(nav[0], nav[1], 28, WEEK, T, T + 240, pages=nav[2])
    parent = bp.BitPredictor("iode", r, history=hist, eps=EPS)
    parent.observe(scen[0])
    before = parent.priors(1)
    child = parent.fork()
    wrong = scen[1].copy()
    wrong[bp.IODE_POSITIONS[-1]] ^= 1  # an IODE copy decided wrongly: the child falls back to the mask
    child.observe(wrong)
    assert parent.n_observed == 1 and child.n_observed == 2
    assert np.array_equal(parent.priors(1), before)
    fresh = bp.BitPredictor("iode", r, history=hist, eps=EPS)
    fresh.observe(scen[0])
    fresh.observe(wrong)
    assert np.array_equal(child.priors(2), fresh.priors(2))
    assert child.mode(2) == "mask"


def test_upload_at_the_next_frame_boundary_is_mispredicted_exactly_where_the_sets_differ(nav):
    eph, header, pages = nav
    prn = 30
    cut = 3  # the upload cuts in at the start of frame 3
    hist, clean = history_and_scenario(nav, prn)
    _, scen = history_and_scenario(nav, prn, [Upload(prn, T + 30 * cut - 12)])
    r = bp.robust_prediction(eph, header, prn, WEEK, T, T + 240, pages=pages)
    p = bp.BitPredictor("iode", r, history=hist)
    wrong = {}
    for k in range(len(scen)):
        pred = p.predicted_bits(k)
        wrong[k] = np.flatnonzero((pred >= 0) & (pred != scen[k]))
        if k == cut:
            assert p.mode(k) == "iode" and (pred >= 0).all()
            assert np.array_equal(pred, clean[k])  # the old data set's bits
            differ = np.flatnonzero(clean[k] != scen[k])
            assert np.array_equal(wrong[k], differ) and len(differ) > 50
            assert differ.min() >= 60 and differ.max() < 900  # never in TLM/HOW of SF1, never in SF4/5
            assert not np.isin(differ % 300, np.arange(60)).any()
        p.observe(scen[k])
    assert [len(w) for k, w in wrong.items() if k != cut] == [0] * (len(scen) - 1)
    assert p.mode(cut + 1) == "mask"  # new IODE in all three copies != stored one: fall back for one frame
    assert p.mode(cut + 2) == "iode"  # then the new set is predicted
    new_iode = bp.iode_copies(bp.decode_frame(scen[cut])[0])
    assert len(set(new_iode)) == 1 and new_iode != bp.iode_copies(bp.decode_frame(clean[cut])[0])


@pytest.mark.parametrize("position", [300 + 60 + 3, 2 * 300 + 270 + 7, 210])  # SF2 IODE, SF3 IODE, SF1 IODC LSBs
def test_a_flipped_iode_decision_falls_back_to_the_mask(nav, position):
    eph, header, pages = nav
    hist, scen = history_and_scenario(nav, 1)
    r = bp.robust_prediction(eph, header, 1, WEEK, T, T + 240, pages=pages)
    p = bp.BitPredictor("iode", r, history=hist)
    p.observe(scen[0])
    p.observe(scen[1])
    bad = scen[2].copy()
    bad[position] ^= 1
    p.observe(bad)
    copies = bp.iode_copies(bp.decode_frame(bad)[0])
    assert len(set(copies)) == 2  # exactly one copy changed
    assert p.mode(3) == "mask"
    mask_only = bp.BitPredictor("mask", r)
    assert np.array_equal(p.priors(3), mask_only.priors(3))
    p.observe(scen[3])
    assert p.mode(4) == "iode"  # agrees again with the last consistent IODE (frame 1)


# ---- driver: priors, Fig. 4 map, bad input -----------------------------------------------------------------


def test_priors_of_each_strategy(nav, robust):
    r = robust[1]
    none = bp.BitPredictor("none", n_frames=3)
    assert (none.priors(0) == 0.5).all() and none.mode(2) == "none"
    mask = bp.BitPredictor("mask", r, eps=0.01)
    bits, m = r.frame(4)
    pr = mask.priors(4)
    assert (pr[m & (bits == 0)] == 0.99).all() and (pr[m & (bits == 1)] == 0.01).all() and (pr[~m] == 0.5).all()
    assert np.mean(pr != 0.5) == m.mean()
    # IODE mode with open IODE copies: the 24 copy bits keep prior 1/2, everything else predicted
    eph, header, pages = nav
    hist = frames_of(build_message(eph, header, 1, WEEK, T - 750, T - 1, pages=pages).bits)
    opened = bp.BitPredictor("iode", r, history=hist, open_iode=True)
    po = opened.priors(0)
    assert (po[bp.IODE_POSITIONS] == 0.5).all() and np.sum(po == 0.5) == 24
    # without a page history the IODE mode still predicts SF1-3, SF4/5 from the mask (pages known)
    short = bp.BitPredictor("iode", r, history=hist[-3:])
    assert short.mode(0) == "iode"
    assert np.array_equal(short.priors(0)[900:], bp.BitPredictor("mask", r).priors(0)[900:])
    assert np.array_equal(short.priors(0), bp.BitPredictor("iode", r, history=hist).priors(0))  # pages known = pages read


def test_prediction_map_is_figure_4(nav, robust):
    r = robust[1]
    p = bp.BitPredictor("mask", r)
    last_bits = r.frame(0)[0]
    left, right = bp.prediction_map(last_bits, p.priors(1))
    assert left.shape == right.shape == (50, 30)
    assert (left[0, :8] == [-1, 1, 1, 1, -1, 1, -1, -1]).all()  # preamble 10001011 as levels 1 - 2 bit
    assert (right == 0).sum() == (~r.frame(1)[1]).sum()
    bits1, m1 = r.frame(1)
    assert np.array_equal(right.reshape(-1)[m1], 1 - 2 * bits1[m1].astype(int))


def test_bad_inputs_are_refused(nav, robust):
    r = robust[1]
    with pytest.raises(ValueError, match="strategy"):
        bp.BitPredictor("all", r)
    with pytest.raises(ValueError, match="robust"):
        bp.BitPredictor("mask")
    with pytest.raises(ValueError, match="eps"):
        bp.BitPredictor("mask", r, eps=0.7)
    with pytest.raises(ValueError, match="history"):
        bp.BitPredictor("iode", r, history=np.zeros(1500, dtype=int))
    p = bp.BitPredictor("iode", r)
    with pytest.raises(ValueError, match="observe frame 1 first"):
        p.priors(2)
    with pytest.raises(ValueError, match="frame_bits_decided"):
        p.observe(np.zeros(1499, dtype=int))
    with pytest.raises(ValueError, match="frame_bits_decided"):
        p.observe(np.full(1500, 2))
    with pytest.raises(ValueError, match="frame_index"):
        p.priors(25)
    with pytest.raises(ValueError, match="t_next_frame"):
        bp.predict_next_frame(np.zeros((2, 1500), dtype=int), T + 6)
    with pytest.raises(ValueError, match="t_start"):
        bp.robust_mask(nav[0], nav[1], 1, WEEK, T, T)
