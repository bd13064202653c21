"""RINEX broadcast ephemerides in LNAV units: values read by hand from the committed file."""

from pathlib import Path

import pytest

from scintrack.signals.gps import ephemeris, lnav

RINEX = Path(__file__).resolve().parents[1] / "data" / "ephemerides" / "brdc2800.15n"


@pytest.fixture(scope="module")
def ephs():
    return ephemeris.load(RINEX)


def test_first_record_of_prn1_matches_the_file_text(ephs):
    # first record of the file (lines 9-16), read by eye:
    #  1 15 10  7  0  0  0.0 0.187428668141D-05 0.795807864051D-12 0.000000000000D+00
    #     0.700000000000D+02-0.673437500000D+02 0.442661285405D-08-0.106626835218D+00
    e = ephemeris.by_prn(ephs)[1][0]
    assert e.prn == 1 and e.week == 1865
    assert e.fields["a_f0"] == pytest.approx(0.187428668141e-05, rel=1e-12)
    assert e.fields["a_f1"] == pytest.approx(0.795807864051e-12, rel=1e-12)
    assert e.iode == 70 and e.iodc == 70
    assert e.fields["c_rs"] == pytest.approx(-67.34375)
    # angles are converted to semicircles with the spec's pi
    assert e.fields["delta_n"] == pytest.approx(0.442661285405e-08 / 3.1415926535898, rel=1e-12)
    assert e.fields["m0"] == pytest.approx(-0.106626835218 / 3.1415926535898, rel=1e-12)
    assert e.t_oc == 259200.0 == e.t_oe  # Wednesday 00:00 GPS time
    assert e.fields["wn"] == 1865 % 1024


def test_upload_data_set_is_out_of_sequence(ephs):
    iodes = [(e.t_oe, e.iode) for e in ephemeris.by_prn(ephs)[1]]
    # the notes (gps-lnav-mm.md 1.4): PRN 1 IODE 72 -> 1 with t_oe 03:59:44 (273584 s)
    assert (273584.0, 1) in iodes and (273600.0, 72) in iodes


def test_every_data_set_fits_the_message_fields(ephs):
    # every field quantises into its width at its scale; decoding gives it back within half an LSB
    for e in ephs:
        for sf in (1, 2, 3):
            t0 = 259200 + 6 * (sf - 1)
            fields = lnav.read_fields(lnav.source_bits(t0, e.fields))
            for name, f in lnav.FIELDS[sf].items():
                assert abs(fields[name] - e.fields[name]) <= 2.0 ** f.scale / 2 + 1e-30, (e.prn, name)


def test_ura_index_bounds():
    assert [ephemeris.ura_index(v) for v in (2.0, 2.8, 4.0, 5.7, 8.0, 11.3, 16.0, 32.0, 7000.0)] == [0, 1, 2, 3, 4, 5, 6, 7, 15]


def test_header(ephs):
    h = ephemeris.read_header(RINEX)
    assert h.alpha[0] == pytest.approx(0.1490e-07) and h.beta[3] == pytest.approx(-0.6554e05)
    assert h.leap_seconds == 17 and h.wn_t == 1865 and h.t_ot == 405504
    assert h.a0 == pytest.approx(-0.931322574615e-09)


def test_bad_file_is_named(tmp_path):
    bad = tmp_path / "broken.15n"
    bad.write_text("not a rinex file\n")
    with pytest.raises(ValueError, match="broken.15n"):
        ephemeris.load(bad)
