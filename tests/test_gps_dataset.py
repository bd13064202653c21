"""The jammed GPS scenario dataset: physical consistency, message alignment, C/N0 profile, determinism."""

import copy

import numpy as np
import pytest

from scintrack.config import load_config
from scintrack.data.gps_jamming_build import build
from scintrack.data.gps_jamming_spec import LAMBDA_L1, C, gps_jamming_params, gps_jamming_version
from scintrack.io import content_hash
from scintrack.project import project_file
from scintrack.signals.gps import jamming, message

START_UTC = "2015-10-07T10:27:00"  # inside the window where PRNs 1, 11, 28, 30 are up (docs/gps-jamming.md)


def small_config(**changes):
    cfg = copy.deepcopy(load_config([str(project_file("config/config.yaml"))]))
    g = cfg["gps_jamming"]
    g.update(duration_s=20.0, start_utc=START_UTC, message_lead_s=30.0, uploads=[{"prn": 11, "time_s": 10.0}])
    g["jammer"] = {**g["jammer"], "onset_s": 8.0}
    g.update(changes)
    return cfg


@pytest.fixture(scope="module")
def ds():
    params = gps_jamming_params(small_config())
    return build(params, project_file(params["ephemerides"]))


def test_pseudorange_is_range_plus_clocks_plus_delays(ds):
    res = ds.pseudorange - ds.range - C * (ds.rx_clock - ds.sat_clock) - ds.iono - ds.tropo
    assert float(abs(res).max()) < 1e-5  # float32 storage of the delays
    # and the arrival times say the same: pseudorange = c (arrival on the receiver clock - SV transmit time)
    rt = ds.receive_time.values
    dpr = np.diff(ds.pseudorange.values, axis=1)
    assert np.allclose(C * (np.diff(rt, axis=1) - 1e-3), dpr, atol=1e-4)
    rng = ds.range.values
    assert 20.0e6 < rng.min() and rng.max() < 26.0e6


def test_doppler_is_the_carrier_phase_rate(ds):
    rt = ds.receive_time.values
    rate = np.diff(ds.carrier_phase.values, axis=1) / np.diff(rt, axis=1)
    mid = 0.5 * (ds.doppler.values[:, 1:] + ds.doppler.values[:, :-1])
    err = rate - mid
    # the difference is the receiver clock's white-FM phase noise: sqrt(h0/2 / dt) f_L1 = 1.6 Hz rms over 1 ms
    assert abs(err.mean()) < 0.05 and 0.5 < err.std() < 2.5
    assert np.all(np.abs(ds.doppler.values) < 5000.0)
    # a positive Doppler (approaching satellite) compresses the code period: spacing = 1 ms (1 - doppler / f_L1)
    spacing = np.diff(rt, axis=1).mean(axis=1)
    assert np.allclose(spacing, 1e-3 * (1 - ds.doppler.mean("epoch").values * LAMBDA_L1 / C), rtol=0, atol=1e-11)


def test_bits_constant_over_20_code_periods_and_equal_to_the_message(ds):
    for k in range(ds.sizes["sv"]):
        b = ds.bit.isel(sv=k).values
        start = (20 - int(ds.first_epoch_in_bit.isel(sv=k))) % 20
        blocks = b[start : start + 20 * ((len(b) - start) // 20)].reshape(-1, 20)
        assert (blocks == blocks[:, :1]).all()
        levels = blocks[:, 0]
        nav = 1 - 2 * ds.nav_bits.isel(sv=k).values.astype(int)
        # the received bit sequence is a contiguous run of the stored message
        hits = [j for j in range(len(nav) - len(levels)) if np.array_equal(nav[j : j + len(levels)], levels)]
        assert len(hits) == 1


def test_message_decodes_with_valid_parity_and_time(ds):
    t0 = float(ds.attrs["t_start_sow"])
    for k in range(ds.sizes["sv"]):
        subframes = message.decode_message(ds.nav_bits.isel(sv=k).values)
        assert len(subframes) >= ds.sizes["subframe"] - 1
        assert all(s.ok for s in subframes)
        starts = ds.subframe_start.values
        for s in subframes:
            assert np.isclose(s.t0 - t0, starts[np.argmin(np.abs(starts - (s.t0 - t0)))])


def test_upload_changes_all_three_iode_copies_out_of_sequence(ds):
    k = int(np.flatnonzero(ds.prn.values == 11)[0])
    kind = ds.dataset_kind.isel(sv=k).values
    iode = ds.iode.isel(sv=k).values
    sid = ds.subframe_id.values
    first = int(np.flatnonzero(kind == "upload")[0])
    assert sid[first] == 1 and ds.subframe_start.values[first] >= 10.0  # cut in at a frame boundary after 10 s
    before = set(iode[:first][sid[:first] <= 3])
    after = set(iode[first : first + 3])
    assert len(before) == 1 and len(after) == 1 and before != after
    for j in np.flatnonzero(ds.prn.values != 11):
        assert "upload" not in set(ds.dataset_kind.isel(sv=int(j)).values)


def test_cn0_profile_from_js_and_spectral_separation(ds):
    cn0 = ds.cn0.values
    before = ds.receive_time.values < 8.0
    assert np.all(cn0[before] == 46.0)
    kappa = jamming.spectral_separation(8e6)
    want = float(jamming.effective_cn0_dbhz(46.0, 54.14, kappa))
    assert np.allclose(cn0[~before], want) and abs(want - 15.0) < 0.5


def test_content_hash_is_deterministic_and_follows_the_seed():
    cfg = small_config(duration_s=4.0, uploads=[])
    params = gps_jamming_params(cfg)
    a = build(params, project_file(params["ephemerides"]))
    b = build(params, project_file(params["ephemerides"]))
    assert content_hash(a) == content_hash(b)
    cfg["seed"] = cfg["seed"] + 1
    other = gps_jamming_params(cfg)
    assert gps_jamming_version(other) != gps_jamming_version(params)
    c = build(other, project_file(other["ephemerides"]))
    assert content_hash(c) != content_hash(a)  # clock realisation and carrier phase offsets change
    # the geometry does not depend on the seed: only the clock and the phase offsets do
    assert np.allclose(c.range.values, a.range.values, atol=1e-3)


def test_wrong_ephemerides_checksum_is_named(tmp_path):
    params = gps_jamming_params(small_config(duration_s=4.0))
    bad = tmp_path / "brdc2800.15n"
    bad.write_bytes(project_file(params["ephemerides"]).read_bytes()[:-10])
    with pytest.raises(ValueError, match="sha256.*registry"):
        build(params, bad)


def test_almanac_pages_carry_every_satellite_of_the_file(ds):
    # subframe 5 pages 1-24 carry the almanac of SV = page (all 32 PRNs are in the file): no dummy SV ID 0
    sid, page = ds.subframe_id.values, ds.page.values
    sf5 = (sid == 5) & (page >= 1) & (page <= 24)
    assert sf5.any()
    for k in range(ds.sizes["sv"]):
        assert np.array_equal(ds.sv_id.isel(sv=k).values[sf5], page[sf5])
