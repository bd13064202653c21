"""GPS satellite position, velocity and clock from a broadcast ephemeris (IS-GPS-200 Table 20-IV).

Implements the user algorithm for ephemeris determination of IS-GPS-200
Table 20-IV and the satellite clock correction of Sec. 20.3.3.3.3.1:

* Kepler's equation ``M_k = E_k - e sin E_k`` is solved by Newton's method,
  vectorised, to ``|dE| < 1e-12`` rad (``KEPLER_TOL``), starting from
  ``E = M + e sin M``; more than ``KEPLER_MAX_ITER`` iterations raise.
* ``t_k = t - t_oe`` (and ``t - t_oc``) follows the week-crossover rule of
  the spec: 604800 s is subtracted above +302400 s and added below -302400 s.
  ``t`` is GPS time in seconds of the ephemeris's week (``Ephemeris.week``).
* The position is the spec's: at GPS time ``t`` and expressed in the ECEF
  frame of that same instant (Earth rotation during signal transit is the
  caller's business, see :mod:`scintrack.signals.gps.geometry`).
* The velocity is the analytic time derivative of those equations (the rate
  of the ECEF coordinates, i.e. relative to the rotating frame, with
  ``dOmega_k/dt = Omega_dot - Omega_e_dot``); it is not a finite difference.
* Clock: ``dt_sv = a_f0 + a_f1 dt + a_f2 dt^2 + F e sqrt(A) sin E_k - T_GD``
  with ``dt = t - t_oc`` (crossover rule applied), ``T_GD`` included because
  the user is an L1 C/A single-frequency receiver (Sec. 20.3.3.3.3.2).  The
  spec evaluates the polynomial at GPS time ``t``; the caller passes the
  transmit time in GPS time (the difference from using ``t_sv`` is below
  1e-15 s).  The drift is the analytic derivative
  ``a_f1 + 2 a_f2 dt + F e sqrt(A) cos E_k dE_k/dt``.

Ephemeris angles arrive in semicircles (the LNAV unit of
:mod:`scintrack.signals.gps.ephemeris`) and are converted with the spec's
``pi = 3.1415926535898`` (``GPS_PI``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scintrack.signals.gps.ephemeris import GPS_PI, SECONDS_PER_WEEK, Ephemeris

#: WGS 84 value of the Earth's gravitational constant for GPS users (m^3/s^2).
MU = 3.986005e14
#: WGS 84 value of the Earth's rotation rate (rad/s).
OMEGA_E_DOT = 7.2921151467e-5
#: Relativistic clock constant F = -2 sqrt(mu)/c^2 (s/sqrt(m)).
F_REL = -4.442807633e-10
#: Speed of light (m/s), as the spec defines it.
C_LIGHT = 2.99792458e8
HALF_WEEK = SECONDS_PER_WEEK // 2
KEPLER_TOL = 1e-12
KEPLER_MAX_ITER = 30

_REQUIRED = ("sqrt_a", "e", "m0", "delta_n", "omega", "omega0", "omega_dot", "i0", "idot",
             "c_uc", "c_us", "c_rc", "c_rs", "c_ic", "c_is", "t_oe", "t_oc", "a_f0", "a_f1", "a_f2", "t_gd")


@dataclass(frozen=True)
class SatState:
    """Satellite state at the requested GPS times (n samples).

    ``position`` / ``velocity``: ECEF (m, m/s), shape (n, 3), in the ECEF frame
    of each time; ``clock_bias``: dt_sv (s), already including the relativistic
    term and -T_GD; ``clock_drift``: d(dt_sv)/dt (s/s); ``relativistic``: the
    F e sqrt(A) sin E_k part (s); ``ecc_anomaly``: E_k (rad).
    """

    position: np.ndarray
    velocity: np.ndarray
    clock_bias: np.ndarray
    clock_drift: np.ndarray
    relativistic: np.ndarray
    ecc_anomaly: np.ndarray


def week_crossover(dt: np.ndarray) -> np.ndarray:
    """Time difference folded into [-302400, 302400] s (IS-GPS-200 Table 20-IV note)."""
    dt = np.asarray(dt, dtype=float)
    return dt - SECONDS_PER_WEEK * (dt > HALF_WEEK) + SECONDS_PER_WEEK * (dt < -HALF_WEEK)


def solve_kepler(mean_anomaly: np.ndarray, e: float) -> np.ndarray:
    """Eccentric anomaly E (rad) with ``M = E - e sin E`` solved to ``KEPLER_TOL`` by Newton's method."""
    if not 0.0 <= e < 1.0:
        raise ValueError(f"eccentricity must be in [0, 1) for an elliptic orbit (got e={e})")
    m = np.asarray(mean_anomaly, dtype=float)
    ecc = m + e * np.sin(m)
    for _ in range(KEPLER_MAX_ITER):
        step = (ecc - e * np.sin(ecc) - m) / (1.0 - e * np.cos(ecc))
        ecc = ecc - step
        if np.all(np.abs(step) < KEPLER_TOL):
            return ecc
    raise ValueError(f"Kepler's equation did not converge in {KEPLER_MAX_ITER} iterations (e={e})")


def _fields(eph: Ephemeris) -> dict[str, float]:
    missing = [name for name in _REQUIRED if name not in eph.fields]
    if missing:
        raise ValueError(f"ephemeris of PRN {eph.prn} lacks {', '.join(missing)}; build it with ephemeris.load()")
    return {name: float(eph.fields[name]) for name in _REQUIRED}


def _times(t: np.ndarray | float) -> np.ndarray:
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if t.ndim != 1:
        raise ValueError(f"t must be a scalar or a 1-D array of GPS seconds of week (got shape {t.shape})")
    if not np.all(np.isfinite(t)):
        raise ValueError("t must be finite GPS seconds of week")
    return t


def satellite_state(eph: Ephemeris, t: np.ndarray | float) -> SatState:
    """Position, velocity and clock of ``eph``'s satellite at GPS times ``t`` (seconds of ``eph.week``)."""
    p = _fields(eph)
    t = _times(t)
    a = p["sqrt_a"] ** 2
    e = p["e"]
    n = np.sqrt(MU / a**3) + p["delta_n"] * GPS_PI
    tk = week_crossover(t - p["t_oe"])
    ecc = solve_kepler(p["m0"] * GPS_PI + n * tk, e)
    sin_e, cos_e = np.sin(ecc), np.cos(ecc)
    one_m_ecos = 1.0 - e * cos_e
    ecc_dot = n / one_m_ecos
    root = np.sqrt(1.0 - e * e)
    nu = np.arctan2(root * sin_e, cos_e - e)
    nu_dot = root * ecc_dot / one_m_ecos

    phi = nu + p["omega"] * GPS_PI
    s2, c2 = np.sin(2.0 * phi), np.cos(2.0 * phi)
    u = phi + p["c_us"] * s2 + p["c_uc"] * c2
    r = a * one_m_ecos + p["c_rs"] * s2 + p["c_rc"] * c2
    inc = p["i0"] * GPS_PI + p["idot"] * GPS_PI * tk + p["c_is"] * s2 + p["c_ic"] * c2
    u_dot = nu_dot * (1.0 + 2.0 * (p["c_us"] * c2 - p["c_uc"] * s2))
    r_dot = a * e * sin_e * ecc_dot + 2.0 * nu_dot * (p["c_rs"] * c2 - p["c_rc"] * s2)
    inc_dot = p["idot"] * GPS_PI + 2.0 * nu_dot * (p["c_is"] * c2 - p["c_ic"] * s2)

    xp, yp = r * np.cos(u), r * np.sin(u)
    xp_dot = r_dot * np.cos(u) - r * u_dot * np.sin(u)
    yp_dot = r_dot * np.sin(u) + r * u_dot * np.cos(u)

    node_rate = p["omega_dot"] * GPS_PI - OMEGA_E_DOT
    node = p["omega0"] * GPS_PI + node_rate * tk - OMEGA_E_DOT * p["t_oe"]
    sin_o, cos_o = np.sin(node), np.cos(node)
    sin_i, cos_i = np.sin(inc), np.cos(inc)
    x = xp * cos_o - yp * cos_i * sin_o
    y = xp * sin_o + yp * cos_i * cos_o
    z = yp * sin_i
    vx = xp_dot * cos_o - yp_dot * cos_i * sin_o + yp * sin_i * inc_dot * sin_o - node_rate * y
    vy = xp_dot * sin_o + yp_dot * cos_i * cos_o - yp * sin_i * inc_dot * cos_o + node_rate * x
    vz = yp_dot * sin_i + yp * cos_i * inc_dot

    dt = week_crossover(t - p["t_oc"])
    rel = F_REL * e * p["sqrt_a"] * sin_e
    bias = p["a_f0"] + p["a_f1"] * dt + p["a_f2"] * dt**2 + rel - p["t_gd"]
    drift = p["a_f1"] + 2.0 * p["a_f2"] * dt + F_REL * e * p["sqrt_a"] * cos_e * ecc_dot
    return SatState(
        position=np.column_stack((x, y, z)), velocity=np.column_stack((vx, vy, vz)),
        clock_bias=bias, clock_drift=drift, relativistic=rel, ecc_anomaly=ecc,
    )


def fit_interval_s(eph: Ephemeris) -> float:
    """Curve-fit interval (s): ``fit_hours``, or 4 h when RINEX left it 0/unknown (fit flag 0, Sec. 20.3.4.4)."""
    hours = eph.fit_hours if eph.fit_hours and np.isfinite(eph.fit_hours) else 4.0
    return hours * 3600.0
