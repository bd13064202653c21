"""Simple L1 signal delays: Klobuchar ionosphere (IS-GPS-200 Fig. 20-4) and a Saastamoinen troposphere.

Both are the "user" models a single-frequency receiver would apply, so a
simulated signal that carries exactly these delays is consistent with the
navigation message it broadcasts; they are not meant as truth of the real
atmosphere on 2015-10-07.

Ionosphere: the single-frequency algorithm of IS-GPS-200 Sec. 20.3.3.5.2.5 /
Fig. 20-4, with the header's alpha/beta (``ephemeris.read_header``), in
semicircle units with the spec's pi.  GPS time in the local-time equation is
the receive time in seconds of week; it is folded into [0, 86400) as the spec
requires.  The result is the L1 group delay, returned in metres (times c).

Troposphere (the spec is silent; our choice):

* zenith delay: Saastamoinen (1972) hydrostatic + wet terms,
  ``ZHD = 0.0022768 P / (1 - 0.00266 cos 2phi - 0.00028 H_km)`` and
  ``ZWD = 0.002277 (1255/T + 0.05) e`` (P, e in hPa, T in K);
* meteorology: a standard atmosphere at the receiver's height (ellipsoidal
  height used as orthometric; the ~30 m geoid difference changes ZHD by
  < 1 cm): ``P = 1013.25 (1 - 2.2557e-5 h)^5.2568`` hPa,
  ``T = 288.15 - 0.0065 h`` K, relative humidity 50 % by default (a middle
  value; no weather for the scenario is known), water-vapour pressure from the
  Magnus-type formula ``e = RH 6.108 exp(17.15 (T-273.15)/(T-38.45))``;
* mapping: ``m(el) = 1.001 / sqrt(0.002001 + sin^2 el)`` (Black & Eisner
  1984, the one of the SBAS MOPS, RTCA DO-229).  It is 1/sin(el) within
  1.5 % above 15 deg and 0.4 % above 30 deg elevation, but stays finite
  (~22.4) at the horizon, which plain 1/sin(el) does not; the same factor is
  used for the hydrostatic and wet terms.
"""

from __future__ import annotations

import numpy as np

from scintrack.signals.gps.ephemeris import GPS_PI, NavHeader
from scintrack.signals.gps.orbit import C_LIGHT

SECONDS_PER_DAY = 86400.0
#: Night-time (constant) term of the Klobuchar model (s).
KLOBUCHAR_NIGHT_S = 5.0e-9


def _coeffs(name: str, values) -> np.ndarray:
    arr = np.asarray(values, dtype=float)
    if arr.shape != (4,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be 4 finite Klobuchar coefficients (ION ALPHA/BETA of the RINEX header)")
    return arr


def klobuchar_delay_s(alpha, beta, lat_deg, lon_deg, az_deg, el_deg, gps_sow) -> np.ndarray:
    """L1 ionospheric group delay (s) of IS-GPS-200 Fig. 20-4; all angle/time inputs broadcast."""
    alpha, beta = _coeffs("alpha", alpha), _coeffs("beta", beta)
    phi_u = np.asarray(lat_deg, dtype=float) / 180.0  # semicircles
    lam_u = np.asarray(lon_deg, dtype=float) / 180.0
    az = np.deg2rad(np.asarray(az_deg, dtype=float))
    el = np.asarray(el_deg, dtype=float) / 180.0  # semicircles
    psi = 0.0137 / (el + 0.11) - 0.022  # Earth-centred angle to the pierce point
    phi_i = np.clip(phi_u + psi * np.cos(az), -0.416, 0.416)
    lam_i = lam_u + psi * np.sin(az) / np.cos(phi_i * GPS_PI)
    phi_m = phi_i + 0.064 * np.cos((lam_i - 1.617) * GPS_PI)  # geomagnetic latitude
    t_local = np.mod(4.32e4 * lam_i + np.asarray(gps_sow, dtype=float), SECONDS_PER_DAY)
    slant = 1.0 + 16.0 * (0.53 - el) ** 3
    amp = np.maximum(np.polynomial.polynomial.polyval(phi_m, alpha), 0.0)
    per = np.maximum(np.polynomial.polynomial.polyval(phi_m, beta), 72000.0)
    x = 2.0 * GPS_PI * (t_local - 50400.0) / per
    day = KLOBUCHAR_NIGHT_S + amp * (1.0 - x**2 / 2.0 + x**4 / 24.0)
    return slant * np.where(np.abs(x) < 1.57, day, KLOBUCHAR_NIGHT_S)


def klobuchar_delay_m(header: NavHeader, lat_deg, lon_deg, az_deg, el_deg, gps_sow) -> np.ndarray:
    """Klobuchar L1 delay in metres, with alpha/beta from a RINEX navigation header."""
    if not isinstance(header, NavHeader):
        raise ValueError("header must be the NavHeader of ephemeris.read_header(path)")
    return C_LIGHT * klobuchar_delay_s(header.alpha, header.beta, lat_deg, lon_deg, az_deg, el_deg, gps_sow)


def standard_atmosphere(height_m, rel_humidity: float = 0.5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(pressure hPa, temperature K, water-vapour pressure hPa) of the standard atmosphere at ``height_m``."""
    if not 0.0 <= rel_humidity <= 1.0:
        raise ValueError(f"rel_humidity must be a fraction in [0, 1] (got {rel_humidity})")
    h = np.asarray(height_m, dtype=float)
    if np.any(h < -500.0) or np.any(h > 11000.0):
        raise ValueError("height_m must be within the troposphere model's range -500..11000 m")
    pressure = 1013.25 * (1.0 - 2.2557e-5 * h) ** 5.2568
    temp = 288.15 - 0.0065 * h
    vapour = rel_humidity * 6.108 * np.exp(17.15 * (temp - 273.15) / (temp - 38.45))
    return pressure, temp, vapour


def saastamoinen_zenith_m(lat_deg, height_m, rel_humidity: float = 0.5) -> np.ndarray:
    """Zenith tropospheric delay (m): Saastamoinen hydrostatic + wet with the standard atmosphere."""
    pressure, temp, vapour = standard_atmosphere(height_m, rel_humidity)
    lat = np.deg2rad(np.asarray(lat_deg, dtype=float))
    zhd = 0.0022768 * pressure / (1.0 - 0.00266 * np.cos(2.0 * lat) - 0.00028 * np.asarray(height_m, dtype=float) / 1000.0)
    zwd = 0.002277 * (1255.0 / temp + 0.05) * vapour
    return zhd + zwd


def tropo_mapping(el_deg) -> np.ndarray:
    """Black & Eisner elevation mapping ``1.001 / sqrt(0.002001 + sin^2 el)``."""
    s = np.sin(np.deg2rad(np.asarray(el_deg, dtype=float)))
    return 1.001 / np.sqrt(0.002001 + s * s)


def tropo_delay_m(lat_deg, height_m, el_deg, rel_humidity: float = 0.5) -> np.ndarray:
    """Slant tropospheric delay (m) at elevation ``el_deg`` (negative elevations use the horizon value)."""
    return saastamoinen_zenith_m(lat_deg, height_m, rel_humidity) * tropo_mapping(np.maximum(el_deg, 0.0))
