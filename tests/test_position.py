"""Least-squares GPS fix (scintrack.navigation.position): exact recovery, DOP, noise covariance, ENU errors.

Pseudoranges are built here from the IS-GPS-200 orbit (``orbit.satellite_state``)
with the light-time equation solved by a fixed-point iteration written in this
file (independently of ``geometry.signal_truth``, which is only used as a
cross-check), for the paper's receiver and PRNs 1, 11, 28, 30 of
brdc2800.15n at 2015-10-07 10:27:17 GPS (week 1865, 296837 s).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pymap3d
import pytest

from scintrack.navigation import position
from scintrack.seeding import rng_for
from scintrack.signals.gps import ephemeris, geometry
from scintrack.signals.gps.orbit import satellite_state

NAV = Path(__file__).resolve().parents[1] / "data" / "ephemerides" / "brdc2800.15n"
C = 2.99792458e8
WE = 7.2921151467e-5
WEEK, T_RX = 1865, 296837.0
PAPER_PRNS = (1, 11, 28, 30)
#: Eight satellites above 10 deg at T_RX (elevations 10-80 deg), for the redundant fix.
EIGHT_PRNS = (1, 7, 8, 9, 11, 19, 28, 30)
CLOCK_BIAS_M = 0.25e-3 * C  # a 0.25 ms receiver clock offset


@pytest.fixture(scope="module")
def ephs():
    return ephemeris.by_prn(ephemeris.load(NAV))


@pytest.fixture(scope="module")
def rx():
    return geometry.paper_receiver_ecef()


def rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def build(ephs, rx, prns, t_rx=T_RX, bias_m=CLOCK_BIAS_M):
    """(sat_pos at transmit time, pseudoranges, dt_sv, satellite positions in the receive-time frame)."""
    sat, rho, clk, rotated = [], [], [], []
    for prn in prns:
        eph = geometry.data_set_for(ephs[prn], WEEK, t_rx)
        tau = 0.0
        for _ in range(8):  # c tau = |R3(w tau) r_s(t_rx - tau) - r|, a contraction (factor ~1e-5)
            state = satellite_state(eph, t_rx - tau)
            r_rot = rot_z(WE * tau) @ state.position[0]
            tau = np.linalg.norm(r_rot - rx) / C
        sat.append(state.position[0])
        rotated.append(r_rot)
        clk.append(state.clock_bias[0])
        rho.append(C * tau + bias_m - C * state.clock_bias[0])
    return np.array(sat), np.array(rho), np.array(clk), np.array(rotated)


def hand_cofactor(rotated, rx):
    los = rotated - rx
    u = los / np.linalg.norm(los, axis=1)[:, None]
    g = np.column_stack((-u, np.ones(len(u))))
    return g, np.linalg.inv(g.T @ g)


def hand_enu_matrix(lat_deg, lon_deg):
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    return np.array([
        [-np.sin(lon), np.cos(lon), 0.0],
        [-np.sin(lat) * np.cos(lon), -np.sin(lat) * np.sin(lon), np.cos(lat)],
        [np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)],
    ])


def test_noise_free_fix_recovers_truth(ephs, rx):
    sat, rho, clk, rotated = build(ephs, rx, PAPER_PRNS)
    for k, prn in enumerate(PAPER_PRNS):  # the test's light-time solution agrees with geometry's
        truth = geometry.signal_truth(geometry.data_set_for(ephs[prn], WEEK, T_RX), rx, T_RX)
        assert abs(rho[k] + C * clk[k] - CLOCK_BIAS_M - truth["range_m"][0]) < 1e-4
        np.testing.assert_allclose(rotated[k], truth["sat_pos"][0], atol=1e-4)
    fix = position.solve(sat, rho, clk)
    assert np.linalg.norm(fix.position - rx) < 1e-3
    assert abs(fix.clock_bias_m - CLOCK_BIAS_M) < 1e-3
    assert np.max(np.abs(fix.residuals)) < 1e-4  # four satellites: exactly determined
    # the Sagnac rotation matters (tens of metres here) ...
    assert np.linalg.norm(position.solve(sat, rho, clk, sagnac=False).position - rx) > 5.0
    # ... and is not applied twice to positions already in the receive-time frame
    again = position.solve(rotated, rho, clk, x0=rx + 1000.0, sagnac=False)
    assert np.linalg.norm(again.position - rx) < 1e-3


def test_vectorised_over_epochs(ephs, rx):
    times = T_RX + np.array([0.0, 60.0, 120.0])
    built = [build(ephs, rx, PAPER_PRNS, t, CLOCK_BIAS_M + 30.0 * k) for k, t in enumerate(times)]
    sat, rho, clk = (np.stack([b[i] for b in built]) for i in range(3))
    fix = position.solve(sat, rho, clk)
    assert fix.position.shape == (3, 3) and fix.residuals.shape == (3, 4) and fix.dop["gdop"].shape == (3,)
    assert np.max(np.linalg.norm(fix.position - rx, axis=1)) < 1e-3
    np.testing.assert_allclose(fix.clock_bias_m, CLOCK_BIAS_M + 30.0 * np.arange(3), atol=1e-3)
    single = position.solve(sat[2], rho[2], clk[2])
    np.testing.assert_allclose(single.position, fix.position[2], atol=1e-6)


def test_dop_matches_geometry_and_hand_computation(ephs, rx):
    sat, rho, clk, rotated = build(ephs, rx, PAPER_PRNS)
    fix = position.solve(sat, rho, clk)
    az, el = geometry.look_angles(rx, rotated)
    ref = geometry.dop(az, el)
    for key in position.DOP_KEYS:
        np.testing.assert_allclose(fix.dop[key], ref[key], rtol=1e-8)
    # hand: Q in ECEF; trace / clock terms are rotation invariant, H/V need the ENU rotation
    _, q = hand_cofactor(rotated, rx)
    lat, lon, _ = pymap3d.ecef2geodetic(*rx)
    q_enu = hand_enu_matrix(lat, lon) @ q[:3, :3] @ hand_enu_matrix(lat, lon).T
    np.testing.assert_allclose(fix.dop["gdop"], np.sqrt(np.trace(q)), rtol=1e-8)
    np.testing.assert_allclose(fix.dop["pdop"], np.sqrt(np.trace(q[:3, :3])), rtol=1e-8)
    np.testing.assert_allclose(fix.dop["tdop"], np.sqrt(q[3, 3]), rtol=1e-8)
    np.testing.assert_allclose(fix.dop["hdop"], np.sqrt(q_enu[0, 0] + q_enu[1, 1]), rtol=1e-8)
    np.testing.assert_allclose(fix.dop["vdop"], np.sqrt(q_enu[2, 2]), rtol=1e-8)
    assert 6.0 < fix.dop["gdop"] < 7.0  # the notes: GDOP ~6.0-6.7 around 10:14-10:30 UTC


@pytest.mark.parametrize("elev", [15.0, 40.0])
def test_dop_closed_form_symmetric_constellation(rx, elev):
    """Zenith + three satellites 120 deg apart at ``elev``: E/N/V/T DOP in closed form.

    G^T G is block diagonal: EE = NN = 3 cos^2(el)/2, and the (U, T) block
    [[1 + 3 s^2, -(1 + 3 s)], [-(1 + 3 s), 4]] (s = sin el) with determinant 3 (1 - s)^2.
    """
    lat, lon, h = pymap3d.ecef2geodetic(*rx)
    az = np.array([0.0, 0.0, 120.0, 240.0])
    el = np.array([90.0, elev, elev, elev])
    sats = np.column_stack(pymap3d.aer2ecef(az, el, 2.0e7, lat, lon, h))
    got = position.dop(sats, rx)
    s, c = np.sin(np.radians(elev)), np.cos(np.radians(elev))
    np.testing.assert_allclose(got["edop"], np.sqrt(2.0 / (3.0 * c**2)), rtol=1e-9)
    np.testing.assert_allclose(got["ndop"], np.sqrt(2.0 / (3.0 * c**2)), rtol=1e-9)
    np.testing.assert_allclose(got["vdop"], np.sqrt(4.0 / (3.0 * (1.0 - s) ** 2)), rtol=1e-9)
    np.testing.assert_allclose(got["tdop"], np.sqrt((1.0 + 3.0 * s**2) / (3.0 * (1.0 - s) ** 2)), rtol=1e-9)


@pytest.mark.parametrize("prns", [PAPER_PRNS, EIGHT_PRNS], ids=["4sv", "8sv"])
def test_noise_covariance_monte_carlo(ephs, rx, prns):
    """Errors with pseudorange noise sigma: covariance sigma^2 (G^T G)^-1, residual RSS ~ sigma^2 chi2(n - 4).

    N = 1000 draws.  Whitened errors w = L^-1 e (L L^T the predicted
    covariance) are N(0, I_4): sum |w|^2 ~ chi2(4N) (mean 4N, sd sqrt(8N)),
    each sample variance has sd sqrt(2/N) = 0.045, each sample correlation
    and mean sd 1/sqrt(N) = 0.032; all are tested at 4 sd.  Per draw the
    error must also equal the linear LS map (G^T G)^-1 G^T n (the
    linearisation error is ~ sigma^2 / range ~ 1e-6 m).
    """
    n_draws, sigma = 1000, 3.0
    sat, rho, clk, rotated = build(ephs, rx, prns)
    noise = sigma * rng_for(20151007, "test_position_mc", len(prns)).standard_normal((n_draws, len(prns)))
    fix = position.solve(np.broadcast_to(sat, (n_draws,) + sat.shape), rho + noise, clk)
    err = np.column_stack((fix.position - rx, fix.clock_bias_m - CLOCK_BIAS_M))
    g, q = hand_cofactor(rotated, rx)
    np.testing.assert_allclose(err, noise @ (q @ g.T).T, atol=1e-4)
    w = np.linalg.solve(np.linalg.cholesky(sigma**2 * q), err.T).T
    chi2 = np.sum(w**2)
    assert abs(chi2 - 4 * n_draws) < 4.0 * np.sqrt(8.0 * n_draws)
    cov = w.T @ w / n_draws
    assert np.all(np.abs(np.diag(cov) - 1.0) < 4.0 * np.sqrt(2.0 / n_draws))
    assert np.all(np.abs(cov[~np.eye(4, dtype=bool)]) < 4.0 / np.sqrt(n_draws))
    assert np.all(np.abs(w.mean(axis=0)) < 4.0 / np.sqrt(n_draws))
    dof = len(prns) - 4
    rss = np.sum(fix.residuals**2, axis=1) / sigma**2
    if dof == 0:
        assert np.max(np.abs(fix.residuals)) < 1e-4
    else:  # chi2(dof): mean dof, sd sqrt(2 dof / N) for the average
        assert abs(rss.mean() - dof) < 4.0 * np.sqrt(2.0 * dof / n_draws)


def test_enu_errors(rx):
    lat, lon, h = pymap3d.ecef2geodetic(*rx)
    offsets = np.array([[0.0, 0.0, 0.0], [3.9, 0.2, 0.5], [-10.0, 25.0, -7.5]])
    pts = np.column_stack(pymap3d.enu2ecef(offsets[:, 0], offsets[:, 1], offsets[:, 2], lat, lon, h))
    got = position.enu_errors(pts, lat, lon, h)
    np.testing.assert_allclose(got, offsets, atol=1e-6)
    # independent: the local rotation of the ECEF difference (exact for a rigid rotation)
    np.testing.assert_allclose(got, (pts - rx) @ hand_enu_matrix(lat, lon).T, atol=1e-6)
    assert position.enu_errors(pts[1], lat, lon, h).shape == (3,)


def test_bad_input(ephs, rx):
    sat, rho, clk, _ = build(ephs, rx, PAPER_PRNS)
    with pytest.raises(ValueError, match="n >= 4"):
        position.solve(sat[:3], rho[:3], clk[:3])
    with pytest.raises(ValueError, match="broadcast"):
        position.solve(sat, rho[:3], clk)
    with pytest.raises(ValueError, match="finite"):
        position.solve(sat, np.r_[rho[:3], np.nan], clk)
    with pytest.raises(ValueError, match="singular"):
        position.solve(np.stack([sat[0]] * 4), rho, clk)
    with pytest.raises(ValueError, match="did not converge"):
        position.solve(sat, rho, clk, iterations=1)
    with pytest.raises(ValueError, match=r"\(\.\.\., 3\)"):
        position.enu_errors(np.zeros(2), 0.0, 0.0, 0.0)
