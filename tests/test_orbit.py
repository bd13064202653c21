"""Broadcast-orbit evaluation: against a scalar re-derivation from IS-GPS-200 Table 20-IV, physics, derivatives."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from scintrack.signals.gps import ephemeris
from scintrack.signals.gps.orbit import (
    OMEGA_E_DOT,
    SatState,
    satellite_state,
    solve_kepler,
    week_crossover,
)

NAV = Path(__file__).resolve().parents[1] / "data" / "ephemerides" / "brdc2800.15n"


@pytest.fixture(scope="module")
def ephs():
    return ephemeris.by_prn(ephemeris.load(NAV))


@pytest.fixture(scope="module")
def rinex_records():
    """Raw RINEX values (radians, as georinex reads them) for PRNs 1, 11, 28, 30; no semicircle conversion."""
    import georinex

    nav = georinex.load(NAV)
    out = {}
    for prn in (1, 11, 28, 30):
        sat = nav.sel(sv=f"G{prn:02d}").dropna("time", how="all")
        out[prn] = [{k: float(sat[k].values[i]) for k in sat.data_vars} for i in range(sat.sizes["time"])]
    return out


def spec_position_clock(rec: dict, t: float, t_oc: float) -> tuple[tuple[float, float, float], float]:
    """IS-GPS-200 Table 20-IV written out scalar, from RINEX radians; Kepler by fixed-point iteration."""
    mu, we, f_rel = 3.986005e14, 7.2921151467e-5, -4.442807633e-10
    a = rec["sqrtA"] ** 2
    n = math.sqrt(mu / a**3) + rec["DeltaN"]
    tk = t - rec["Toe"]
    if tk > 302400:
        tk -= 604800
    elif tk < -302400:
        tk += 604800
    mk = rec["M0"] + n * tk
    ek = mk
    for _ in range(60):
        ek = mk + rec["Eccentricity"] * math.sin(ek)
    e = rec["Eccentricity"]
    vk = math.atan2(math.sqrt(1 - e * e) * math.sin(ek), math.cos(ek) - e)
    phik = vk + rec["omega"]
    du = rec["Cus"] * math.sin(2 * phik) + rec["Cuc"] * math.cos(2 * phik)
    dr = rec["Crs"] * math.sin(2 * phik) + rec["Crc"] * math.cos(2 * phik)
    di = rec["Cis"] * math.sin(2 * phik) + rec["Cic"] * math.cos(2 * phik)
    uk = phik + du
    rk = a * (1 - e * math.cos(ek)) + dr
    ik = rec["Io"] + di + rec["IDOT"] * tk
    xk1, yk1 = rk * math.cos(uk), rk * math.sin(uk)
    om = rec["Omega0"] + (rec["OmegaDot"] - we) * tk - we * rec["Toe"]
    x = xk1 * math.cos(om) - yk1 * math.cos(ik) * math.sin(om)
    y = xk1 * math.sin(om) + yk1 * math.cos(ik) * math.cos(om)
    z = yk1 * math.sin(ik)
    dt = t - t_oc
    clock = (rec["SVclockBias"] + rec["SVclockDrift"] * dt + rec["SVclockDriftRate"] * dt * dt
             + f_rel * e * rec["sqrtA"] * math.sin(ek) - rec["TGD"])
    return (x, y, z), clock


def test_position_matches_scalar_spec_evaluation(ephs, rinex_records):
    checked = 0
    for prn, records in rinex_records.items():
        for rec in records[::3]:
            eph = next(e for e in ephs[prn] if e.t_oe == rec["Toe"] and e.iode == int(rec["IODE"]))
            times = rec["Toe"] + np.array([-7200.0, -1234.5, 0.0, 3600.0, 7199.0])
            state = satellite_state(eph, times)
            for k, t in enumerate(times):
                pos, clock = spec_position_clock(rec, float(t), eph.t_oc)
                assert np.linalg.norm(state.position[k] - np.array(pos)) < 1e-3
                assert abs(state.clock_bias[k] - clock) < 1e-15
                checked += 1
    assert checked >= 60


def test_radius_and_period(ephs):
    eph = ephs[11][6]
    a = eph.fields["sqrt_a"] ** 2
    e = eph.fields["e"]
    assert 26_500e3 < a < 26_620e3  # semi-major axis of the GPS constellation
    n = math.sqrt(3.986005e14 / a**3) + eph.fields["delta_n"] * ephemeris.GPS_PI
    period = 2 * math.pi / n
    assert abs(period - 43_082.0) < 60.0  # half a sidereal day
    t = eph.t_oe + np.linspace(-7200, 7200, 301)
    radius = np.linalg.norm(satellite_state(eph, t).position, axis=1)
    assert np.all(radius > a * (1 - e) - 1e3) and np.all(radius < a * (1 + e) + 1e3)

    # one orbital period later the satellite is back at (nearly) the same inertial position; half a period later it is across
    def inertial(tt):
        pos = satellite_state(eph, np.array([tt])).position[0]
        ang = -OMEGA_E_DOT * tt  # ECEF at GPS time tt -> frame aligned with ECEF at the week start
        c, s = math.cos(ang), math.sin(ang)
        return np.array([c * pos[0] + s * pos[1], -s * pos[0] + c * pos[1], pos[2]])

    start = eph.t_oe - period / 2
    assert np.linalg.norm(inertial(start + period) - inertial(start)) < 20e3  # nodal drift + J2 terms
    assert np.linalg.norm(inertial(start + period / 2) - inertial(start)) > 2 * a * (1 - e) - 100e3


@pytest.mark.parametrize("prn", [1, 11, 28, 30])
def test_velocity_and_drift_are_derivatives(ephs, prn):
    eph = ephs[prn][4]
    t = eph.t_oe + np.linspace(-7000, 7000, 57)
    h = 1.0
    state = satellite_state(eph, t)
    fd = (satellite_state(eph, t + h).position - satellite_state(eph, t - h).position) / (2 * h)
    assert np.max(np.linalg.norm(state.velocity - fd, axis=1)) < 1e-4  # FD truncation (h^2/6 x jerk) is ~1.5e-5 m/s
    assert 2500 < np.linalg.norm(state.velocity, axis=1).min()  # ECEF speed of a GPS satellite ~3-4 km/s
    fd_clock = (satellite_state(eph, t + h).clock_bias - satellite_state(eph, t - h).clock_bias) / (2 * h)
    assert np.max(np.abs(state.clock_drift - fd_clock)) < 1e-18


@pytest.mark.parametrize("prn", [1, 11, 28, 30])
def test_consecutive_data_sets_agree_at_cutover(ephs, prn):
    """Real broadcast data: neighbouring data sets fit the same orbit, so they agree to metres where they meet."""
    group = ephs[prn]
    for old, new in zip(group[:-1], group[1:]):
        t = np.array([(old.t_oe + new.t_oe) / 2.0])
        a, b = satellite_state(old, t), satellite_state(new, t)
        assert np.linalg.norm(a.position - b.position) < 5.0
        assert np.linalg.norm(a.velocity - b.velocity) < 2e-3
        assert abs(a.clock_bias[0] - b.clock_bias[0]) * 2.99792458e8 < 3.0


def test_week_crossover_rule(ephs):
    eph = ephs[30][3]
    assert week_crossover(np.array([302401.0, -302401.0, 5.0]))[0] == 302401.0 - 604800
    assert week_crossover(np.array([-302401.0]))[0] == -302401.0 + 604800
    t = eph.t_oe + 1000.0
    same = satellite_state(eph, np.array([t, t - 604800.0, t + 604800.0]))
    assert np.allclose(same.position, same.position[0], atol=1e-6, rtol=0)
    assert np.allclose(same.clock_bias, same.clock_bias[0], atol=1e-18, rtol=0)


def test_kepler_solution_accuracy():
    m = np.linspace(-10, 10, 2001)
    for e in (0.0, 0.005, 0.02, 0.3, 0.7):
        ecc = solve_kepler(m, e)
        assert np.max(np.abs(ecc - e * np.sin(ecc) - m)) < 1e-12
    with pytest.raises(ValueError, match="eccentricity"):
        solve_kepler(m, 1.2)


def test_relativistic_term_and_types(ephs):
    eph = ephs[28][2]
    state = satellite_state(eph, eph.t_oe + np.arange(0.0, 43082.0, 500.0))
    assert isinstance(state, SatState) and state.position.shape == (87, 3)
    amp = -4.442807633e-10 * eph.fields["e"] * eph.fields["sqrt_a"]
    assert np.max(np.abs(state.relativistic)) == pytest.approx(abs(amp), rel=1e-3)  # sin E sweeps +-1 in a period
    assert satellite_state(eph, eph.t_oe).position.shape == (1, 3)


def test_bad_input(ephs):
    eph = ephs[1][0]
    with pytest.raises(ValueError, match="finite"):
        satellite_state(eph, np.array([np.nan]))
    with pytest.raises(ValueError, match="1-D"):
        satellite_state(eph, np.zeros((2, 2)))
    broken = replace(eph, fields={k: v for k, v in eph.fields.items() if k != "sqrt_a"})
    with pytest.raises(ValueError, match="sqrt_a"):
        satellite_state(broken, 0.0)
