"""Receiver-satellite geometry, DOP, window choice and the Klobuchar/Saastamoinen delays."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from scintrack.signals.gps import ephemeris
from scintrack.signals.gps.atmosphere import (
    klobuchar_delay_m,
    klobuchar_delay_s,
    saastamoinen_zenith_m,
    tropo_delay_m,
    tropo_mapping,
)
from scintrack.signals.gps.geometry import (
    data_set_for,
    dop,
    look_angles,
    paper_receiver_ecef,
    parse_dms,
    receiver_ecef,
    select_window,
    signal_truth,
    visible,
)
from scintrack.signals.gps.orbit import satellite_state

NAV = Path(__file__).resolve().parents[1] / "data" / "ephemerides" / "brdc2800.15n"
C = 2.99792458e8
WE = 7.2921151467e-5
PAPER_ECEF = np.array([197025.850, -4755021.170, 4232127.262])


@pytest.fixture(scope="module")
def ephs():
    return ephemeris.by_prn(ephemeris.load(NAV))


@pytest.fixture(scope="module")
def header():
    return ephemeris.read_header(NAV)


@pytest.fixture(scope="module")
def rx():
    return paper_receiver_ecef()


def test_paper_receiver_position():
    lat = parse_dms("41°50'12.9264\"N")
    lon = parse_dms("-87°37'38.2368'' W")  # the paper's own spelling: minus and W mean one west sign
    assert lat == pytest.approx(41 + 50 / 60 + 12.9264 / 3600, abs=1e-12)
    assert lon == pytest.approx(-(87 + 37 / 60 + 38.2368 / 3600), abs=1e-12)
    assert np.linalg.norm(receiver_ecef(lat, lon, 2.0) - PAPER_ECEF) < 0.01
    assert np.linalg.norm(paper_receiver_ecef() - PAPER_ECEF) < 0.01
    assert parse_dms("33 52 4.2 S") == pytest.approx(-(33 + 52 / 60 + 4.2 / 3600))
    for bad in ("41°70'0\"N", "-41°0'0\"N", "north"):
        with pytest.raises(ValueError):
            parse_dms(bad)


def test_look_angles_simple_cases(rx):
    lat, lon = math.radians(parse_dms("41°50'12.9264\"N")), math.radians(parse_dms("87°37'38.2368\"W"))
    up = np.array([math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon), math.sin(lat)])
    north = np.array([-math.sin(lat) * math.cos(lon), -math.sin(lat) * math.sin(lon), math.cos(lat)])
    east = np.array([-math.sin(lon), math.cos(lon), 0.0])
    d = 2.0e7
    sats = np.array([rx + d * up, rx + d * (north + up) / math.sqrt(2), rx + d * east, rx - d * east + 0.1 * d * up])
    az, el = look_angles(rx, sats)
    assert el[0] == pytest.approx(90.0, abs=1e-6)
    assert (az[1], el[1]) == pytest.approx((0.0, 45.0), abs=1e-6)
    assert (az[2], el[2]) == pytest.approx((90.0, 0.0), abs=1e-6)
    assert az[3] == pytest.approx(270.0, abs=1e-6) and el[3] == pytest.approx(math.degrees(math.atan(0.1)), abs=1e-6)


@pytest.mark.parametrize("elev", [10.0, 30.0, 55.0])
def test_dop_closed_form(elev):
    """One satellite at zenith, three at elevation el spaced 120 deg: G^T G is block diagonal with closed-form inverse."""
    rot = 17.0  # an arbitrary azimuth rotation leaves every DOP unchanged
    az = np.array([0.0, rot, rot + 120.0, rot + 240.0])
    el = np.array([90.0, elev, elev, elev])
    s, c = math.sin(math.radians(elev)), math.cos(math.radians(elev))
    e2 = n2 = 2.0 / (3.0 * c * c)
    v2 = 4.0 / (3.0 * (1.0 - s) ** 2)
    t2 = (3.0 * s * s + 1.0) / (3.0 * (1.0 - s) ** 2)
    d = dop(az, el)
    expected = {"edop": e2, "ndop": n2, "vdop": v2, "tdop": t2, "hdop": e2 + n2, "pdop": e2 + n2 + v2, "gdop": e2 + n2 + v2 + t2}
    for key, value in expected.items():
        assert float(d[key]) == pytest.approx(math.sqrt(value), rel=1e-10), key
    # batched over leading axes, and a degenerate geometry (all at one point) is infinite
    batch = dop(np.stack([az, az]), np.stack([el, el]))
    assert batch["gdop"].shape == (2,)
    assert np.isinf(dop(np.zeros(4), np.full(4, 45.0))["gdop"])
    with pytest.raises(ValueError):
        dop(az[:3], el[:3])


def _visible_samples(ephs, rx, prns, min_el):
    for prn in prns:
        for eph in ephs[prn][::2]:
            truth = signal_truth(eph, rx, eph.t_oe + np.arange(-7200.0, 7200.0, 120.0))
            yield eph, truth, truth["el_deg"] >= min_el


def test_range_envelope_and_transit(ephs, rx):
    count = 0
    for eph, truth, up in _visible_samples(ephs, rx, sorted(ephs), 5.0):
        rng = truth["range_m"][up]
        a, e = eph.fields["sqrt_a"] ** 2, eph.fields["e"]
        # 19,947 km is reached (PRN 19 at 83 deg): perigee radius minus the Earth's, not a flat 20,000 km
        assert np.all(rng > a * (1 - e) - np.linalg.norm(rx) - 1e3)
        assert np.all(rng > 19_800e3) and np.all(rng < 26_000e3)
        assert np.allclose(truth["transit_s"], truth["range_m"] / C, atol=1e-12, rtol=0)
        count += up.sum()
    assert count > 1000
    for _, truth, up in _visible_samples(ephs, rx, (1, 11, 28, 30), 10.0):
        assert np.all((truth["range_m"][up] > 20_000e3) & (truth["range_m"][up] < 26_000e3))


def test_light_time_equation_holds_independently(ephs, rx):
    """c tau = |R3(w tau) r_s(t_rx - tau) - r_rx| re-evaluated here from the orbit alone."""
    eph = ephs[28][6]
    t_rx = eph.t_oe + np.array([-3000.0, 0.0, 2500.0])
    truth = signal_truth(eph, rx, t_rx)
    for k, t in enumerate(t_rx):
        tau = truth["transit_s"][k]
        x, y, z = satellite_state(eph, np.array([t - tau])).position[0]
        th = WE * tau
        rotated = np.array([x * math.cos(th) + y * math.sin(th), -x * math.sin(th) + y * math.cos(th), z])
        assert abs(np.linalg.norm(rotated - rx) - C * tau) < 1e-4
        assert np.linalg.norm(rotated - truth["sat_pos"][k]) < 1e-6
        assert truth["t_tx"][k] == pytest.approx(t - tau, abs=1e-9)


def test_range_rate_is_derivative_of_range(ephs, rx):
    h = 0.5
    for prn in (1, 11, 28, 30):
        eph = ephs[prn][6]
        t = eph.t_oe + np.linspace(-6000, 6000, 41)
        rate = signal_truth(eph, rx, t)["range_rate_m_s"]
        fd = (signal_truth(eph, rx, t + h)["range_m"] - signal_truth(eph, rx, t - h)["range_m"]) / (2 * h)
        # FD error here is ~1e-6 m/s; dropping the light-time factor or its rotation part costs 0.3-1 mm/s
        assert np.max(np.abs(rate - fd)) < 2e-5
        assert np.max(np.abs(rate)) < 1000.0  # a static receiver sees |range rate| < ~930 m/s


def test_sagnac_term(ephs, rx):
    largest = 0.0
    for _eph, truth, up in _visible_samples(ephs, rx, sorted(ephs), 0.0):
        xs, ys = truth["sat_pos"][:, 0], truth["sat_pos"][:, 1]
        closed_form = WE / C * (xs * rx[1] - ys * rx[0])
        assert np.max(np.abs(truth["sagnac_m"] - closed_form)) < 5e-3
        largest = max(largest, float(np.max(np.abs(truth["sagnac_m"][up]), initial=0.0)))
    assert 20.0 < largest < 45.0


def test_visible_matches_elevation(ephs, rx):
    eph = ephs[30][6]
    t = eph.t_oe + np.arange(-7200.0, 7200.0, 600.0)
    el = signal_truth(eph, rx, t)["el_deg"]
    assert np.array_equal(visible(eph, rx, t, 10.0), el >= 10.0)


def klobuchar_reference(alpha, beta, lat, lon, az, el, gps_time):
    """IS-GPS-200 Fig. 20-4 written out scalar (semicircles, pi as the spec defines it)."""
    pi = 3.1415926535898
    phi_u, lam_u, e = lat / 180.0, lon / 180.0, el / 180.0
    a_rad = math.radians(az)
    psi = 0.0137 / (e + 0.11) - 0.022
    phi_i = phi_u + psi * math.cos(a_rad)
    phi_i = min(max(phi_i, -0.416), 0.416)
    lam_i = lam_u + psi * math.sin(a_rad) / math.cos(phi_i * pi)
    phi_m = phi_i + 0.064 * math.cos((lam_i - 1.617) * pi)
    t = 4.32e4 * lam_i + gps_time
    while t >= 86400:
        t -= 86400
    while t < 0:
        t += 86400
    f = 1.0 + 16.0 * (0.53 - e) ** 3
    amp = sum(alpha[n] * phi_m**n for n in range(4))
    per = sum(beta[n] * phi_m**n for n in range(4))
    amp, per = max(amp, 0.0), max(per, 72000.0)
    x = 2 * pi * (t - 50400) / per
    if abs(x) < 1.57:
        return f * (5e-9 + amp * (1 - x * x / 2 + x**4 / 24))
    return f * 5e-9


def test_klobuchar_against_reference_and_envelope(header):
    cases = [(41.8369, -87.6273, 153.0, 10.0, 296800.0), (41.8369, -87.6273, 267.7, 23.1, 297000.0),
             (-33.9, 151.2, 20.0, 60.0, 259200.0 + 3 * 3600), (60.0, 10.0, 300.0, 5.0, 345000.0), (0.0, 0.0, 0.0, 90.0, 50400.0)]
    for lat, lon, az, el, t in cases:
        got = klobuchar_delay_s(header.alpha, header.beta, lat, lon, az, el, t)
        assert float(got) == pytest.approx(klobuchar_reference(header.alpha, header.beta, lat, lon, az, el, t), rel=1e-12)
    # zenith at local midnight: the night-time floor 5 ns times the slant factor at el = 90 deg
    f_zenith = 1 + 16 * (0.53 - 0.5) ** 3
    night = klobuchar_delay_m(header, 41.8369, -87.6273, 0.0, 90.0, (86400 - 4.32e4 * (-87.6273 / 180)) % 86400)
    assert float(night) == pytest.approx(5e-9 * C * f_zenith, rel=1e-12)
    rng = np.random.default_rng(20151007)
    lat, lon = rng.uniform(-80, 80, 2000), rng.uniform(-180, 180, 2000)
    az, el, t = rng.uniform(0, 360, 2000), rng.uniform(0, 90, 2000), rng.uniform(0, 604800, 2000)
    delay = klobuchar_delay_s(header.alpha, header.beta, lat, lon, az, el, t)
    slant = 1 + 16 * (0.53 - el / 180) ** 3
    amp_max = sum(abs(a) * 0.48**n for n, a in enumerate(header.alpha))  # |phi_m| <= 0.416 + 0.064
    assert np.all(delay >= 5e-9 * slant * (1 - 1e-12)) and np.all(delay <= (5e-9 + amp_max) * slant)
    assert np.all(delay * C < 60.0)


def test_tropo_model():
    # Saastamoinen hydrostatic at sea level, 45 deg (cos 2 phi = 0): 0.0022768 * 1013.25 hPa
    zhd = 0.0022768 * 1013.25
    temp = 288.15
    vapour = 0.5 * 6.108 * math.exp(17.15 * 15.0 / (temp - 38.45))
    zwd = 0.002277 * (1255 / temp + 0.05) * vapour
    assert float(saastamoinen_zenith_m(45.0, 0.0)) == pytest.approx(zhd + zwd, rel=1e-12)
    assert 2.3 < float(saastamoinen_zenith_m(41.8, 2.0)) < 2.5
    assert float(saastamoinen_zenith_m(41.8, 1600.0)) < 0.85 * float(saastamoinen_zenith_m(41.8, 2.0))
    for el, tol in ((15.0, 0.015), (30.0, 0.004), (60.0, 1e-3), (90.0, 1e-3)):
        assert float(tropo_mapping(el)) == pytest.approx(1 / math.sin(math.radians(el)), rel=tol)
    assert float(tropo_mapping(20.0)) == pytest.approx(1.001 / math.sqrt(0.002001 + math.sin(math.radians(20.0)) ** 2), rel=1e-14)
    assert 20.0 < float(tropo_mapping(0.0)) < 25.0
    el = np.linspace(-5, 90, 96)
    delay = tropo_delay_m(41.8, 2.0, el)
    assert np.all(np.diff(delay) <= 0) and np.all(np.isfinite(delay))
    with pytest.raises(ValueError):
        saastamoinen_zenith_m(41.8, 2.0, rel_humidity=1.5)


def test_signal_truth_delays(ephs, rx, header):
    eph = ephs[1][6]
    t = eph.t_oe + np.array([0.0, 1600.0])
    plain = signal_truth(eph, rx, t)
    full = signal_truth(eph, rx, t, iono=header, tropo=True)
    assert np.all(plain["iono_m"] == 0) and np.all(plain["tropo_m"] == 0)
    assert np.array_equal(plain["range_m"], full["range_m"])
    assert np.allclose(full["iono_m"], klobuchar_delay_m(header, 41.836924, -87.627288, full["az_deg"], full["el_deg"], t), rtol=1e-6)
    assert np.all(full["tropo_m"] >= 2.3)


def test_data_set_choice(ephs):
    group = ephs[1]
    chosen = data_set_for(group, 1865, 273590.0)  # between the upload (t_oe 273584) and the 273600 set
    assert chosen.t_oe == 273584.0
    assert data_set_for(group, 1865, 296800.0).t_oe == 295200.0
    assert data_set_for(group, 1865, 200000.0) is None  # outside every fit interval


@pytest.fixture(scope="module")
def paper_window(ephs, rx):
    return select_window(ephs, rx, [1, 11, 28, 30], duration_s=240.0, min_elev_deg=10.0, week=1865, step_s=10.0)


def test_select_window_paper(paper_window, ephs, rx):
    w = paper_window
    assert not w.fallback and w.reason == "" and w.prns == (1, 11, 28, 30)
    assert w.times[0] == w.t_start and w.times[-1] == w.t_start + 240.0 and len(w.times) == 25
    assert np.all(w.el_deg >= 10.0)
    assert w.max_gdop == pytest.approx(np.max(w.dop["gdop"]))
    assert 259200.0 <= w.t_start < 345600.0
    for prn, eph in w.data_sets.items():
        assert abs(w.t_start + 120.0 - eph.t_oe) <= 7200.0
        truth = signal_truth(eph, rx, w.times)
        assert np.allclose(truth["el_deg"], w.el_deg[:, w.prns.index(prn)], atol=0.01)


def _day_geometry(ephs, rx, prns, grid):
    """(az, el) on ``grid`` with the data set of :func:`data_set_for` at each time (nan when none)."""
    az, el = np.full((len(grid), len(prns)), np.nan), np.full((len(grid), len(prns)), np.nan)
    for j, prn in enumerate(prns):
        chosen = [data_set_for(ephs[prn], 1865, float(t)) for t in grid]
        for eph in {id(e): e for e in chosen if e is not None}.values():
            rows = np.array([c is eph for c in chosen])
            truth = signal_truth(eph, rx, grid[rows])
            az[rows, j], el[rows, j] = truth["az_deg"], truth["el_deg"]
    return az, el


def test_select_window_is_min_max_gdop(paper_window, ephs, rx):
    """Brute force over the same 10-s grid of the whole day: no feasible window has a smaller worst-case GDOP."""
    grid = 259200.0 + 10.0 * np.arange(8641)
    az, el = _day_geometry(ephs, rx, (1, 11, 28, 30), grid)
    best, best_start = np.inf, None
    for start in range(len(grid) - 24):
        sl = slice(start, start + 25)
        if np.all(el[sl] >= 10.0):
            worst = float(np.max(dop(az[sl], el[sl])["gdop"]))
            if worst < best:
                best, best_start = worst, grid[start]
    assert paper_window.max_gdop == pytest.approx(best, rel=1e-9)
    assert paper_window.t_start == best_start


def test_select_window_fallback(ephs, rx):
    t_from, t_to = 296400.0, 297600.0
    grid = t_from + 30.0 * np.arange(41)
    below = next(p for p in sorted(ephs) if np.all(~(_day_geometry(ephs, rx, (p,), grid)[1] >= 0.0)))
    w = select_window(ephs, rx, [1, 11, 28, below], 240.0, 10.0, 1865, t_from, t_to, 30.0)
    assert w.fallback and str(below) in w.reason and "never all" in w.reason
    assert below not in w.prns and {1, 11, 28} <= set(w.prns) and len(w.prns) == 4
    assert np.all(w.el_deg >= 10.0)
    # joint optimum over (window, fourth satellite): at the chosen window no other fourth satellite does better
    rows = np.isin(grid, w.times)
    alternatives = []
    for prn in sorted(set(ephs) - {1, 11, 28}):
        az, el = _day_geometry(ephs, rx, (1, 11, 28, prn), grid)
        if np.all(el[rows] >= 10.0):
            alternatives.append(float(np.max(dop(az[rows], el[rows])["gdop"])))
    assert len(alternatives) >= 2
    assert w.max_gdop == pytest.approx(min(alternatives), rel=1e-9)


def test_select_window_bad_input(ephs, rx):
    with pytest.raises(ValueError, match="4 distinct"):
        select_window(ephs, rx, [1, 11, 28])
    with pytest.raises(ValueError, match="whole number"):
        select_window(ephs, rx, [1, 11, 28, 30], duration_s=240.0, step_s=7.0)
    with pytest.raises(ValueError, match="rx_ecef"):
        select_window(ephs, [0.0, 0.0, 0.0], [1, 11, 28, 30])
