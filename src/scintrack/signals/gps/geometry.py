"""Receiver-satellite geometry for a static receiver: light time, Sagnac, look angles, DOP, window choice.

Used to give the simulated signals of the jammed dataset their true range,
range rate and satellite clock, and to pick the 4-minute scenario window.
Geodetic <-> ECEF <-> AER conversions are pymap3d's (WGS 84).

Signal truth (:func:`signal_truth`), for a receiver fixed in ECEF:

* the transit time ``tau`` solves ``c tau = |R3(w tau) r_s(t_rx - tau) - r_rx|``
  by Newton's method (derivative ``c + a - b``, below; 2-3 passes to a step
  < 1e-13 s, so ``range/c`` equals ``tau`` to < 30 um), with ``r_s`` from
  IS-GPS-200 Table 20-IV at GPS transmit time and ``R3(w tau)`` the rotation
  of the ECEF frame during transit (Earth rotation / Sagnac correction,
  ``w = Omega_e_dot``).  ``tau`` is the *vacuum* transit: the few-ns to
  ~100-ns iono/tropo delays are returned separately in metres; the satellite
  moves < 0.5 mm in that extra time, so the positions ignore it.
* the range rate is the exact derivative of that range with respect to the
  receive time, ``rho_dot = a / (1 + (a - b)/c)``, where
  ``a = u . R3 v_s`` and ``b = w u . R3' r_s`` (``u`` the unit line of sight,
  ``R3'`` = dR3/dangle); the ``1/(1 + ...)`` factor is the light-time
  (``d tau/d t_rx = rho_dot / c``) term, ~2 mm/s, kept so the rate is
  consistent with the range to < 1 mm/s.
* the satellite clock correction and drift (L1 C/A, with T_GD and the
  relativistic term) are evaluated at the transmit time.

Window choice (:func:`select_window`): times are scanned on a ``step_s``
grid; for each PRN and time the healthy data set whose t_oe is nearest is
used if the time lies inside its curve-fit interval (t_oe +- fit/2; ties go to
the later transmission).  A window is feasible when every requested PRN is
at or above ``min_elev_deg`` at every grid point of it (with a 1-s grid the
elevation moves < 0.01 deg between points).  Among feasible windows the one
whose *largest* GDOP over the window is smallest is chosen (the worst
geometry the 4-minute scenario will see, min-max; earliest start on a tie).
If no window is feasible, the fallback keeps as many requested PRNs as can
be kept and fills up to four with other healthy satellites, choosing (window,
set) by the same min-max GDOP rule; the result then carries
``fallback=True`` and a reason.
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pymap3d

from scintrack.signals.gps.atmosphere import klobuchar_delay_m, tropo_delay_m
from scintrack.signals.gps.ephemeris import GPS_EPOCH, SECONDS_PER_WEEK, Ephemeris, NavHeader
from scintrack.signals.gps.orbit import C_LIGHT, OMEGA_E_DOT, fit_interval_s, satellite_state, week_crossover

#: The paper's static receiver (Zhao, Khanafseh & Pervan, Sec. IV).
PAPER_LAT_DMS = "41°50'12.9264\"N"
PAPER_LON_DMS = "87°37'38.2368\"W"
PAPER_HEIGHT_M = 2.0

TRANSIT_TOL_S = 1e-13
TRANSIT_MAX_ITER = 10

_DMS = re.compile(
    r"^\s*(?P<sign>[-+])?\s*(?P<deg>\d+(?:\.\d+)?)\s*(?:°|deg|d|\s)\s*"
    r"(?:(?P<min>\d+(?:\.\d+)?)\s*(?:'|′|m|\s)\s*)?"
    r"(?:(?P<sec>\d+(?:\.\d+)?)\s*(?:''|\"|″|s)?\s*)?"
    r"(?P<hem>[NSEWnsew])?\s*$"
)


def parse_dms(text: str) -> float:
    """Decimal degrees of a degree/minute/second string such as ``41°50'12.9264"N`` or ``-87°37'38.2368'' W``.

    S/W or a leading minus make the angle negative; a minus together with S/W
    (as the paper writes the longitude) still means one negative sign.
    """
    m = _DMS.match(text)
    if m is None:
        raise ValueError(f"cannot parse {text!r} as degrees/minutes/seconds (e.g. 41°50'12.9264\"N)")
    minutes = float(m["min"] or 0.0)
    seconds = float(m["sec"] or 0.0)
    if minutes >= 60.0 or seconds >= 60.0:
        raise ValueError(f"minutes and seconds must be < 60 in {text!r}")
    hem = (m["hem"] or "").upper()
    if m["sign"] == "-" and hem in ("N", "E"):
        raise ValueError(f"{text!r} has a minus sign and hemisphere {hem}: drop one of them")
    value = float(m["deg"]) + minutes / 60.0 + seconds / 3600.0
    return -value if (m["sign"] == "-" or hem in ("S", "W")) else value


def receiver_ecef(lat_deg: float, lon_deg: float, h_m: float) -> np.ndarray:
    """WGS 84 ECEF position (m, shape (3,)) of a geodetic position (pymap3d)."""
    if not (-90.0 <= lat_deg <= 90.0 and -180.0 <= lon_deg <= 360.0):
        raise ValueError(f"lat_deg must be in [-90, 90] and lon_deg in [-180, 360] (got {lat_deg}, {lon_deg})")
    return np.array(pymap3d.geodetic2ecef(lat_deg, lon_deg, h_m), dtype=float)


def paper_receiver_ecef() -> np.ndarray:
    """ECEF of the paper's receiver, 41°50'12.9264"N 87°37'38.2368"W, 2 m."""
    return receiver_ecef(parse_dms(PAPER_LAT_DMS), parse_dms(PAPER_LON_DMS), PAPER_HEIGHT_M)


def _rx(rx_ecef) -> np.ndarray:
    rx = np.asarray(rx_ecef, dtype=float)
    if rx.shape != (3,) or not np.all(np.isfinite(rx)) or np.linalg.norm(rx) < 6.0e6:
        raise ValueError("rx_ecef must be one finite ECEF position (x, y, z) in metres near the Earth's surface")
    return rx


def look_angles(rx_ecef, sat_ecef) -> tuple[np.ndarray, np.ndarray]:
    """Azimuth (deg, from north through east, [0, 360)) and elevation (deg) of ``sat_ecef`` (n,3) from ``rx_ecef``."""
    rx = _rx(rx_ecef)
    sat = np.atleast_2d(np.asarray(sat_ecef, dtype=float))
    if sat.shape[-1] != 3:
        raise ValueError(f"sat_ecef must have shape (n, 3) (got {sat.shape})")
    lat, lon, h = pymap3d.ecef2geodetic(*rx)
    az, el, _ = pymap3d.ecef2aer(sat[:, 0], sat[:, 1], sat[:, 2], lat, lon, h)
    return np.asarray(az, dtype=float), np.asarray(el, dtype=float)


def dop(az_deg, el_deg) -> dict[str, np.ndarray]:
    """DOPs of satellites at (az, el) (deg; last axis = satellites, >= 4), from the ENU geometry matrix.

    Rows of G are ``[-e_E, -e_N, -e_U, 1]`` with ``e`` the unit line of sight;
    ``Q = (G^T G)^-1`` gives E/N/V/T DOP as the square roots of its diagonal.
    Singular geometries give inf.
    """
    az = np.deg2rad(np.asarray(az_deg, dtype=float))
    el = np.deg2rad(np.asarray(el_deg, dtype=float))
    if az.shape != el.shape or az.ndim == 0 or az.shape[-1] < 4:
        raise ValueError("az_deg and el_deg must have the same shape with >= 4 satellites on the last axis")
    g = np.stack((-np.cos(el) * np.sin(az), -np.cos(el) * np.cos(az), -np.sin(el), np.ones_like(el)), axis=-1)
    normal = np.einsum("...ki,...kj->...ij", g, g)
    cond = np.linalg.cond(normal)
    bad = ~np.isfinite(cond) | (cond > 1e12)
    normal = np.where(bad[..., None, None], np.eye(4), normal)
    diag = np.diagonal(np.linalg.inv(normal), axis1=-2, axis2=-1).copy()
    diag[bad] = np.inf
    e, n, v, t = (diag[..., k] for k in range(4))
    return {
        "gdop": np.sqrt(e + n + v + t), "pdop": np.sqrt(e + n + v), "hdop": np.sqrt(e + n),
        "vdop": np.sqrt(v), "edop": np.sqrt(e), "ndop": np.sqrt(n), "tdop": np.sqrt(t),
    }


def _rotate_z(pos: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """``R3(angle) pos``: coordinates in a frame rotated by ``angle`` about z (ECEF at a later time)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.column_stack((c * pos[:, 0] + s * pos[:, 1], -s * pos[:, 0] + c * pos[:, 1], pos[:, 2]))


def _rotate_z_prime(pos: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """``dR3/dangle pos``."""
    c, s = np.cos(angle), np.sin(angle)
    return np.column_stack((-s * pos[:, 0] + c * pos[:, 1], -c * pos[:, 0] - s * pos[:, 1], np.zeros(len(pos))))


def signal_truth(eph: Ephemeris, rx_ecef, t_rx, iono: NavHeader | None = None, tropo: bool = False) -> dict[str, np.ndarray]:
    """True geometry of ``eph``'s signal at a static receiver at GPS receive times ``t_rx`` (s of ``eph.week``).

    Returns arrays over t_rx: ``t_tx`` (s), ``transit_s`` (vacuum), ``range_m``,
    ``range_rate_m_s``, ``sat_clock_s`` (dt_sv, L1 C/A), ``sat_clock_drift``,
    ``az_deg``, ``el_deg``, ``iono_m`` (Klobuchar, zeros if ``iono`` is None),
    ``tropo_m`` (zeros unless ``tropo``), ``sagnac_m`` (range minus the range
    without the Earth-rotation term), ``sat_pos`` / ``sat_vel`` (n,3) in the
    ECEF frame of the receive time.
    """
    rx = _rx(rx_ecef)
    t_rx = np.atleast_1d(np.asarray(t_rx, dtype=float))
    if t_rx.ndim != 1 or not np.all(np.isfinite(t_rx)):
        raise ValueError("t_rx must be a scalar or a 1-D array of finite GPS seconds of week")
    tau = np.full(t_rx.shape, 0.075)
    for _ in range(TRANSIT_MAX_ITER):
        state = satellite_state(eph, t_rx - tau)
        angle = OMEGA_E_DOT * tau
        pos = _rotate_z(state.position, angle)
        vel = _rotate_z(state.velocity, angle)
        los = pos - rx
        rng = np.linalg.norm(los, axis=1)
        unit = los / rng[:, None]
        a = np.einsum("ij,ij->i", unit, vel)
        b = OMEGA_E_DOT * np.einsum("ij,ij->i", unit, _rotate_z_prime(state.position, angle))
        step = (C_LIGHT * tau - rng) / (C_LIGHT + a - b)  # Newton on g(tau) = c tau - rho(tau)
        if np.all(np.abs(step) < TRANSIT_TOL_S):
            break
        tau = tau - step
    else:
        raise ValueError(f"light-time iteration for PRN {eph.prn} did not converge; is rx_ecef on the Earth?")
    range_rate = a / (1.0 + (a - b) / C_LIGHT)
    az, el = look_angles(rx, pos)
    out = {
        "t_tx": t_rx - tau, "transit_s": tau, "range_m": rng, "range_rate_m_s": range_rate,
        "sat_clock_s": state.clock_bias, "sat_clock_drift": state.clock_drift,
        "az_deg": az, "el_deg": el,
        "sagnac_m": rng - np.linalg.norm(state.position - rx, axis=1),
        "sat_pos": pos, "sat_vel": vel,
    }
    lat, lon, h = pymap3d.ecef2geodetic(*rx)
    out["iono_m"] = klobuchar_delay_m(iono, lat, lon, az, el, t_rx) if iono is not None else np.zeros_like(rng)
    out["tropo_m"] = tropo_delay_m(lat, h, el) if tropo else np.zeros_like(rng)
    return out


def visible(eph: Ephemeris, rx_ecef, t_rx, min_elev_deg: float = 10.0) -> np.ndarray:
    """Boolean mask of receive times at which ``eph``'s satellite is at or above ``min_elev_deg``."""
    return signal_truth(eph, rx_ecef, t_rx)["el_deg"] >= min_elev_deg


# ----------------------------------------------------------------------------------------------
# window selection


def data_set_for(ephemerides: Sequence[Ephemeris], week: int, t: float) -> Ephemeris | None:
    """Healthy data set with t_oe nearest GPS time (week, t) whose fit interval holds t (None if none)."""
    best, best_key = None, None
    for eph in ephemerides:
        if int(eph.fields.get("health", 0)) != 0:
            continue
        dt = abs(week_crossover((week - eph.week) * SECONDS_PER_WEEK + t - eph.t_oe))
        if dt > fit_interval_s(eph) / 2.0:
            continue
        key = (dt, -eph.transmit_time)
        if best_key is None or key < best_key:
            best, best_key = eph, key
    return best


def _elevations(ephs: Sequence[Ephemeris], rx: np.ndarray, week: int, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(az, el) in deg on ``times`` with the nearest data set per time; nan where none is valid."""
    az = np.full(times.shape, np.nan)
    el = np.full(times.shape, np.nan)
    healthy = [e for e in ephs if int(e.fields.get("health", 0)) == 0]
    if not healthy:
        return az, el
    offsets = np.array([(week - e.week) * SECONDS_PER_WEEK - e.t_oe for e in healthy])
    dist = np.abs(week_crossover(times[:, None] + offsets[None, :]))
    half_fit = np.array([fit_interval_s(e) / 2.0 for e in healthy])
    later = np.array([e.transmit_time for e in healthy])
    # nearest t_oe; among equals the later transmission (lexsort: last key is primary)
    dist_key = np.where(dist <= half_fit[None, :], dist, np.inf)
    order = np.lexsort((-np.broadcast_to(later, dist.shape), dist_key), axis=1)
    choice = order[:, 0]
    ok = np.isfinite(dist_key[np.arange(len(times)), choice])
    for k, eph in enumerate(healthy):
        sel = ok & (choice == k)
        if np.any(sel):
            t_eph = times[sel] + (week - eph.week) * SECONDS_PER_WEEK
            truth = signal_truth(eph, rx, t_eph)
            az[sel], el[sel] = truth["az_deg"], truth["el_deg"]
    return az, el


@dataclass(frozen=True)
class WindowChoice:
    """The chosen scenario window.

    ``times``: GPS seconds of ``week`` on the ``step_s`` grid covering
    [t_start, t_start + duration]; ``az_deg``/``el_deg``: (n_times, n_prn) in
    the order of ``prns``; ``dop``: each DOP over those times; ``max_gdop``:
    the criterion value; ``data_sets``: per PRN the data set valid at the
    window's middle (use one per PRN for a continuous truth); ``fallback``:
    True when ``prns`` differs from the request, with ``reason``.
    """

    week: int
    t_start: float
    duration_s: float
    prns: tuple[int, ...]
    requested_prns: tuple[int, ...]
    times: np.ndarray = field(repr=False)
    az_deg: np.ndarray = field(repr=False)
    el_deg: np.ndarray = field(repr=False)
    dop: dict[str, np.ndarray] = field(repr=False)
    max_gdop: float
    data_sets: dict[int, Ephemeris] = field(repr=False)
    fallback: bool
    reason: str

    @property
    def start_gps(self) -> np.datetime64:
        """Window start as a GPS-time datetime64 (UTC = GPS - leap seconds)."""
        seconds = self.week * SECONDS_PER_WEEK + self.t_start
        return GPS_EPOCH + np.timedelta64(int(round(seconds * 1e6)), "us")


def _sliding(values: np.ndarray, width: int, reducer) -> np.ndarray:
    """``reducer`` over every run of ``width`` consecutive rows (axis 0)."""
    return reducer(np.lib.stride_tricks.sliding_window_view(values, width, axis=0), axis=-1)


def _best_window(az: np.ndarray, el: np.ndarray, width: int, min_elev: float) -> tuple[int, float] | None:
    """(start index, max GDOP) of the feasible window with the smallest max GDOP, or None."""
    low = np.where(np.isnan(el), -np.inf, el)
    feasible = _sliding(low, width, np.min).min(axis=1) >= min_elev
    if not np.any(feasible):
        return None
    gdop = dop(np.nan_to_num(az), np.nan_to_num(el))["gdop"]
    worst = np.where(feasible, _sliding(gdop, width, np.max), np.inf)
    start = int(np.argmin(worst))
    return (start, float(worst[start])) if np.isfinite(worst[start]) else None


def select_window(
    ephemerides_by_prn: Mapping[int, Sequence[Ephemeris]],
    rx_ecef,
    prns: Sequence[int],
    duration_s: float = 240.0,
    min_elev_deg: float = 10.0,
    week: int | None = None,
    t_from: float | None = None,
    t_to: float | None = None,
    step_s: float = 1.0,
) -> WindowChoice:
    """The ``duration_s`` window in [t_from, t_to] (GPS s of ``week``) where ``prns`` have the best min-max GDOP.

    Defaults: ``week`` the most common week of the data sets, ``t_from`` the
    start of the GPS day of the earliest t_oe, ``t_to`` one day later.  See
    the module docstring for the criterion and the fallback.
    """
    rx = _rx(rx_ecef)
    prns = tuple(int(p) for p in prns)
    if len(set(prns)) < 4 or len(set(prns)) != len(prns):
        raise ValueError(f"prns must be at least 4 distinct PRNs for DOP (got {prns})")
    if step_s <= 0 or duration_s <= 0:
        raise ValueError("duration_s and step_s must be > 0")
    width = round(duration_s / step_s)
    if abs(width * step_s - duration_s) > 1e-9:
        raise ValueError(f"duration_s ({duration_s}) must be a whole number of step_s ({step_s})")
    everyone = [e for group in ephemerides_by_prn.values() for e in group]
    if not everyone:
        raise ValueError("ephemerides_by_prn is empty; build it with ephemeris.by_prn(ephemeris.load(path))")
    if week is None:
        weeks, counts = np.unique([e.week for e in everyone], return_counts=True)
        week = int(weeks[np.argmax(counts)])
    if t_from is None:
        first = min(e.t_oe + (e.week - week) * SECONDS_PER_WEEK for e in everyone)
        t_from = float(np.floor(first / 86400.0) * 86400.0)
    if t_to is None:
        t_to = t_from + 86400.0
    if t_to - t_from < duration_s:
        raise ValueError(f"t_to - t_from ({t_to - t_from} s) is shorter than duration_s ({duration_s} s)")
    times = t_from + step_s * np.arange(int(np.floor((t_to - t_from) / step_s)) + 1)

    groups = {int(p): g for p, g in ephemerides_by_prn.items()}
    geometry = {p: _elevations(groups[p], rx, week, times) for p in prns if p in groups}
    missing = [p for p in prns if p not in groups]
    nan = np.full(times.shape, np.nan)

    def stack(sel):
        az = np.column_stack([geometry.get(p, (nan, nan))[0] for p in sel])
        el = np.column_stack([geometry.get(p, (nan, nan))[1] for p in sel])
        return az, el

    fallback, reason, chosen = False, "", None
    if not missing:
        az, el = stack(prns)
        found = _best_window(az, el, width + 1, min_elev_deg)
        if found is not None:
            chosen = (prns, found[0], found[1])
    if chosen is None:
        fallback = True
        geometry.update({p: _elevations(g, rx, week, times) for p, g in groups.items() if p not in geometry})
        chosen = _fallback(geometry, prns, width + 1, min_elev_deg)
        why = f"PRN(s) {missing} have no data set; " if missing else ""
        reason = (f"{why}PRNs {list(prns)} are never all at or above {min_elev_deg} deg for {duration_s} s in "
                  f"[{t_from}, {t_to}]; using {list(chosen[0])} (most requested PRNs kept, then lowest max GDOP)")
    sel, start, max_gdop = chosen
    az, el = stack(sel)
    span = slice(start, start + width + 1)
    middle = times[start] + duration_s / 2.0
    data_sets = {p: data_set_for(groups[p], week, middle) for p in sel}
    return WindowChoice(
        week=week, t_start=float(times[start]), duration_s=float(duration_s), prns=tuple(sel), requested_prns=prns,
        times=times[span], az_deg=az[span], el_deg=el[span], dop=dop(az[span], el[span]),
        max_gdop=max_gdop, data_sets=data_sets, fallback=fallback, reason=reason,
    )


def _fallback(geometry: dict[int, tuple[np.ndarray, np.ndarray]], prns: tuple[int, ...], width: int,
              min_elev: float) -> tuple[tuple[int, ...], int, float]:
    """(PRNs, start index, max GDOP) of the best four satellites: most requested kept, then min-max GDOP."""
    order = sorted(geometry)
    el_all = np.column_stack([np.where(np.isnan(geometry[p][1]), -np.inf, geometry[p][1]) for p in order])
    up = _sliding(el_all, width, np.min) >= min_elev  # (n_windows, n_prn): above for the whole window
    requested = np.array([p in prns for p in order])
    kept = np.minimum((up & requested).sum(axis=1), 4)
    if up.sum(axis=1).max(initial=0) < 4:
        raise ValueError(f"no four satellites stay above {min_elev} deg together for a whole window; lower min_elev_deg")
    feasible_windows = up.sum(axis=1) >= 4
    k_best = int(kept[feasible_windows].max())
    candidates: set[tuple[int, ...]] = set()
    for w in np.flatnonzero(feasible_windows & (kept >= k_best)):
        req = [order[i] for i in np.flatnonzero(up[w] & requested)]
        other = [order[i] for i in np.flatnonzero(up[w] & ~requested)]
        for keep in itertools.combinations(req, k_best):
            for extra in itertools.combinations(other, 4 - k_best):
                candidates.add(tuple(sorted(keep + extra)))
    best = None
    for subset in sorted(candidates):
        az = np.column_stack([geometry[p][0] for p in subset])
        el = np.column_stack([geometry[p][1] for p in subset])
        found = _best_window(az, el, width, min_elev)
        if found is not None and (best is None or found[1] < best[2] or (found[1] == best[2] and found[0] < best[1])):
            best = (subset, found[0], found[1])
    if best is None:  # pragma: no cover - candidates come from feasible windows
        raise ValueError("no feasible fallback window")
    return best
