"""Single-epoch GPS position fix by iterative least squares, with DOP and ENU errors.

Positioning step of the jammed-receiver experiment (Zhao et al., Sec. IV:
ENU position errors of the 4-satellite fix; reference notes gps-lnav-mm.md
Sec. 2.4).  Measurement model for satellite i (IS-GPS-200 Sec. 20.3.3.3.3.1
clock, Table 20-IV orbit)::

    rho_i + c dt_sv,i = | R3(w tau_i) r_s,i - r | + b

* ``r_s,i``: the satellite position at its transmit time, in the ECEF frame
  of that transmit time (what :func:`scintrack.signals.gps.orbit.satellite_state`
  returns at ``t_tx``); ``R3(w tau_i)`` rotates it into the ECEF frame of the
  receive time (Earth rotation during transit, Sagnac correction;
  ``w = Omega_e_dot`` of WGS 84).  ``tau_i`` is the geometric transit time
  ``|R3(w tau_i) r_s,i - r| / c`` from the current position estimate, *not*
  ``rho_i / c`` (the receiver clock bias would mis-rotate by ``w b / c``, up to
  metres).  It is carried through the Gauss-Newton iterations, whose fixed
  point therefore solves the light-time equation exactly.  Pass
  ``sagnac=False`` when the positions are already in the receive-time frame
  (e.g. ``geometry.signal_truth``'s ``sat_pos``).
* ``dt_sv,i``: satellite clock offset (s) including the relativistic term and
  ``-T_GD`` (L1 C/A user), as ``satellite_state`` gives it;
* ``b``: receiver clock bias in metres; no iono/tropo terms (the caller
  removes them from ``rho`` if it models them).

Solution (:func:`solve`): Gauss-Newton on ``[x, y, z, b]`` with rows
``[-u_i, 1]`` (``u_i`` the unit line of sight receiver -> satellite) and the
step from a QR least-squares solve; it starts from the Earth's centre with
``b = 0`` unless ``x0`` is given (from there it converges in ~6 iterations),
and stops once every step is below ``tol_m`` (not converging within
``iterations`` raises).  With exactly four satellites the fix is exactly
determined (zero residuals).  Vectorised over leading epoch axes:
``sat_pos`` (..., n, 3).

DOP (:func:`dop`): ``Q = (G^T G)^-1`` at the solution, the position block
rotated to the local east/north/up frame of the geodetic position of the
solution (WGS 84, pymap3d), returned with the same keys as
:func:`scintrack.signals.gps.geometry.dop`.  ENU errors (:func:`enu_errors`):
``pymap3d.ecef2enu`` about the true geodetic position.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pymap3d

from scintrack.signals.gps.orbit import C_LIGHT, OMEGA_E_DOT

DOP_KEYS = ("gdop", "pdop", "hdop", "vdop", "edop", "ndop", "tdop")


class Fix(NamedTuple):
    """Result of :func:`solve` (leading shape ``...`` of the inputs).

    ``position``: ECEF (m) (..., 3); ``clock_bias_m``: receiver clock bias
    ``c dt_rx`` (m) (...); ``residuals``: measured minus modelled corrected
    pseudorange at the solution (m) (..., n); ``dop``: DOP dict, each (...).
    """

    position: np.ndarray
    clock_bias_m: np.ndarray
    residuals: np.ndarray
    dop: dict[str, np.ndarray]


def rotate_earth(sat_pos: np.ndarray, transit_s: np.ndarray) -> np.ndarray:
    """``R3(w tau) r_s``: positions (..., 3) at transmit time expressed in the ECEF frame ``tau`` s later."""
    angle = OMEGA_E_DOT * np.asarray(transit_s, dtype=float)
    c, s = np.cos(angle), np.sin(angle)
    x, y, z = sat_pos[..., 0], sat_pos[..., 1], sat_pos[..., 2]
    return np.stack((c * x + s * y, -s * x + c * y, z), axis=-1)


def geometry_matrix(sat_pos: np.ndarray, rx_ecef: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(G, ranges)``: rows ``[-u_i, 1]`` (..., n, 4) and geometric ranges (..., n) from ``rx_ecef`` (..., 3)."""
    los = sat_pos - rx_ecef[..., None, :]
    ranges = np.linalg.norm(los, axis=-1)
    g = np.concatenate((-los / ranges[..., None], np.ones(ranges.shape + (1,))), axis=-1)
    return g, ranges


def _ecef_to_enu_matrix(lat_deg: np.ndarray, lon_deg: np.ndarray) -> np.ndarray:
    """Rotation (..., 3, 3) taking ECEF vectors to local east, north, up."""
    lat, lon = np.deg2rad(lat_deg), np.deg2rad(lon_deg)
    sl, cl, sp, cp = np.sin(lon), np.cos(lon), np.sin(lat), np.cos(lat)
    zero = np.zeros_like(sl)
    return np.stack((
        np.stack((-sl, cl, zero), axis=-1),
        np.stack((-sp * cl, -sp * sl, cp), axis=-1),
        np.stack((cp * cl, cp * sl, sp), axis=-1),
    ), axis=-2)


def dop(sat_pos, rx_ecef) -> dict[str, np.ndarray]:
    """DOPs of satellites at ``sat_pos`` (..., n, 3) (receive-time ECEF frame) seen from ``rx_ecef`` (..., 3)."""
    sat_pos, rx = np.asarray(sat_pos, dtype=float), np.asarray(rx_ecef, dtype=float)
    g, _ = geometry_matrix(sat_pos, rx)
    q = _cofactor(g)
    lat, lon, _ = pymap3d.ecef2geodetic(rx[..., 0], rx[..., 1], rx[..., 2])
    m = _ecef_to_enu_matrix(np.asarray(lat), np.asarray(lon))
    q_enu = m @ q[..., :3, :3] @ np.swapaxes(m, -1, -2)
    e, n, v = (q_enu[..., k, k] for k in range(3))
    t = q[..., 3, 3]
    return {
        "gdop": np.sqrt(e + n + v + t), "pdop": np.sqrt(e + n + v), "hdop": np.sqrt(e + n),
        "vdop": np.sqrt(v), "edop": np.sqrt(e), "ndop": np.sqrt(n), "tdop": np.sqrt(t),
    }


def _check_r(r: np.ndarray) -> None:
    diag = np.abs(np.diagonal(r, axis1=-2, axis2=-1))
    if not np.all(diag > 1e-10 * diag.max(axis=-1, keepdims=True)):
        raise ValueError("sat_pos gives a singular geometry (coplanar or repeated satellites); use other satellites")


def _cofactor(g: np.ndarray) -> np.ndarray:
    """``(G^T G)^-1`` (..., 4, 4) via the QR factor of G (raises on a singular geometry)."""
    r = np.linalg.qr(g, mode="r")
    _check_r(r)
    r_inv = np.linalg.inv(r)
    return r_inv @ np.swapaxes(r_inv, -1, -2)


def _ls_step(g: np.ndarray, misfit: np.ndarray) -> np.ndarray:
    """Least-squares solution (..., 4) of ``G step = misfit`` by QR (raises on a singular geometry)."""
    q, r = np.linalg.qr(g)
    _check_r(r)
    return np.linalg.solve(r, np.einsum("...ki,...k->...i", q, misfit)[..., None])[..., 0]


def _inputs(sat_pos, pseudoranges, sat_clock_s) -> tuple[np.ndarray, np.ndarray]:
    sat_pos = np.asarray(sat_pos, dtype=float)
    if sat_pos.ndim < 2 or sat_pos.shape[-1] != 3 or sat_pos.shape[-2] < 4:
        raise ValueError(f"sat_pos must have shape (..., n, 3) with n >= 4 satellites (got {sat_pos.shape})")
    lead = sat_pos.shape[:-1]
    rho = np.asarray(pseudoranges, dtype=float)
    clk = np.asarray(sat_clock_s, dtype=float)
    try:
        corrected = np.broadcast_to(rho, lead) + C_LIGHT * np.broadcast_to(clk, lead)
    except ValueError:
        raise ValueError(f"pseudoranges and sat_clock_s must broadcast to {lead} (got {rho.shape}, {clk.shape})") from None
    if not (np.all(np.isfinite(sat_pos)) and np.all(np.isfinite(corrected))):
        raise ValueError("sat_pos, pseudoranges and sat_clock_s must be finite")
    return sat_pos, corrected


def solve(sat_pos, pseudoranges, sat_clock_s, x0=None, iterations: int = 10, *, sagnac: bool = True,
          tol_m: float = 1e-6) -> Fix:
    """Receiver position and clock bias from ``n >= 4`` pseudoranges (m) by Gauss-Newton (module docstring).

    ``sat_pos`` (..., n, 3) ECEF at transmit time (m), ``pseudoranges`` and
    ``sat_clock_s`` (dt_sv, s) (..., n); ``x0`` an initial ECEF position
    (3,) or (..., 3) (default: the Earth's centre).
    """
    if int(iterations) != iterations or iterations < 1:
        raise ValueError(f"iterations must be an integer >= 1 (got {iterations!r})")
    sat_pos, corrected = _inputs(sat_pos, pseudoranges, sat_clock_s)
    lead = sat_pos.shape[:-2]
    x = np.zeros(lead + (3,))
    if x0 is not None:
        try:
            x = np.array(np.broadcast_to(np.asarray(x0, dtype=float), lead + (3,)))
        except ValueError:
            raise ValueError(f"x0 must be an ECEF position of shape (3,) or {lead + (3,)}") from None
    b = np.zeros(lead)
    tau = np.zeros(corrected.shape)
    for _ in range(int(iterations)):
        sats = rotate_earth(sat_pos, tau) if sagnac else sat_pos
        g, ranges = geometry_matrix(sats, x)
        tau = ranges / C_LIGHT
        misfit = corrected - ranges - b[..., None]
        step = _ls_step(g, misfit)
        x = x + step[..., :3]
        b = b + step[..., 3]
        if np.all(np.abs(step) < tol_m):
            break
    else:
        raise ValueError(f"least squares did not converge to {tol_m} m in {iterations} iterations; raise iterations or give x0")
    sats = rotate_earth(sat_pos, tau) if sagnac else sat_pos
    _, ranges = geometry_matrix(sats, x)
    return Fix(position=x, clock_bias_m=b, residuals=corrected - ranges - b[..., None], dop=dop(sats, x))


def enu_errors(ecef, truth_lat_deg: float, truth_lon_deg: float, truth_h_m: float) -> np.ndarray:
    """East/north/up error (..., 3) in metres of ECEF positions (..., 3) about the true geodetic position (pymap3d)."""
    ecef = np.asarray(ecef, dtype=float)
    if ecef.ndim < 1 or ecef.shape[-1] != 3:
        raise ValueError(f"ecef must have shape (..., 3) (got {ecef.shape})")
    if not (-90.0 <= truth_lat_deg <= 90.0):
        raise ValueError(f"truth_lat_deg must be in [-90, 90] degrees (got {truth_lat_deg})")
    e, n, u = pymap3d.ecef2enu(ecef[..., 0], ecef[..., 1], ecef[..., 2], truth_lat_deg, truth_lon_deg, truth_h_m)
    return np.stack((np.asarray(e), np.asarray(n), np.asarray(u)), axis=-1)
