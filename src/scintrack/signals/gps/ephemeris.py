"""GPS broadcast ephemerides from a RINEX 2 navigation file, in the LNAV message's units.

The file is parsed by ``georinex`` (a maintained RINEX reader); this module
only turns its variables into one :class:`Ephemeris` per broadcast data set,
with the field names and units of :data:`scintrack.signals.gps.lnav.FIELDS`:
seconds, metres, and **semicircles** (semicircles/s) for the angles, which
RINEX stores in radians (converted with the spec's pi = 3.1415926535898).
Two things RINEX does not carry directly are derived:

* the URA index (IS-GPS-200 Sec. 20.3.3.3.1.3) from the nominal URA in metres
  that RINEX writes ("SV accuracy"): the smallest index whose upper bound
  holds the value (2.0 m -> 0, 2.8 m -> 1, 4.0 m -> 2);
* the fit-interval flag from the fit interval in hours (0 for 4 h or unknown,
  1 otherwise, Sec. 20.3.4.4); AODO is not in RINEX 2 and is sent as 0.

The header's Klobuchar coefficients (ION ALPHA/BETA) and UTC parameters
(DELTA-UTC, LEAP SECONDS) are read by :func:`read_header` (georinex returns
the first two only), for page 18 of subframe 4 and the iono model.

A file that cannot be read (not RINEX, truncated, a header line or a record
field blank or garbled) raises :class:`RinexFormatError`, one line naming the
file and what is wrong.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import InputError, one_line
from . import lnav

#: pi as IS-GPS-200 defines it for the user algorithms (Table 20-IV).
GPS_PI = 3.1415926535898
#: GPS time origin.
GPS_EPOCH = np.datetime64("1980-01-06T00:00:00", "ns")
SECONDS_PER_WEEK = 604800

#: Upper bounds (m) of URA indices 0..14 (Sec. 20.3.3.3.1.3); index 15 is "no accuracy prediction".
URA_BOUNDS_M = (2.4, 3.4, 4.85, 6.85, 9.65, 13.65, 24.0, 48.0, 96.0, 192.0, 384.0, 768.0, 1536.0, 3072.0, 6144.0)

#: RINEX variable (georinex name) -> (LNAV field, factor to the spec's unit).
_RINEX_FIELDS = {
    "SVclockBias": ("a_f0", 1.0),
    "SVclockDrift": ("a_f1", 1.0),
    "SVclockDriftRate": ("a_f2", 1.0),
    "Crs": ("c_rs", 1.0),
    "DeltaN": ("delta_n", 1.0 / GPS_PI),
    "M0": ("m0", 1.0 / GPS_PI),
    "Cuc": ("c_uc", 1.0),
    "Eccentricity": ("e", 1.0),
    "Cus": ("c_us", 1.0),
    "sqrtA": ("sqrt_a", 1.0),
    "Toe": ("t_oe", 1.0),
    "Cic": ("c_ic", 1.0),
    "Omega0": ("omega0", 1.0 / GPS_PI),
    "Cis": ("c_is", 1.0),
    "Io": ("i0", 1.0 / GPS_PI),
    "Crc": ("c_rc", 1.0),
    "omega": ("omega", 1.0 / GPS_PI),
    "OmegaDot": ("omega_dot", 1.0 / GPS_PI),
    "IDOT": ("idot", 1.0 / GPS_PI),
    "TGD": ("t_gd", 1.0),
}


class RinexFormatError(InputError):
    """A RINEX navigation file that cannot be read (malformed, truncated, blank or garbled fields)."""


#: georinex variables every data set needs (FitIntvl is optional: 0 = 4 h)
_REQUIRED = (*_RINEX_FIELDS, "CodesL2", "SVacc", "health", "IODC", "IODE", "L2Pflag", "TransTime")


def ura_index(ura_m: float) -> int:
    """URA index of a nominal URA in metres (15 when larger than every bound)."""
    for index, bound in enumerate(URA_BOUNDS_M):
        if ura_m <= bound:
            return index
    return 15


class DataSetFields:
    """Named access to the issue-of-data and reference times of a ``fields`` mapping in LNAV units."""

    fields: dict[str, float]

    @property
    def iode(self) -> int:
        return int(self.fields["iode"])

    @property
    def iodc(self) -> int:
        return int(self.fields["iodc"])

    @property
    def t_oe(self) -> float:
        return float(self.fields["t_oe"])

    @property
    def t_oc(self) -> float:
        return float(self.fields["t_oc"])


@dataclass(frozen=True)
class Ephemeris(DataSetFields):
    """One broadcast data set of one satellite.

    ``fields`` holds every subframe 1-3 field of the LNAV message by its name
    in :data:`~scintrack.signals.gps.lnav.FIELDS`, in the spec's units;
    ``week`` is the full GPS week of ``t_oc``, ``transmit_time`` the RINEX
    transmission time of message (seconds of that week), ``fit_hours`` the
    fit interval.
    """

    prn: int
    week: int
    transmit_time: float
    fit_hours: float
    fields: dict[str, float] = field(repr=False)


@dataclass(frozen=True)
class NavHeader:
    """Header of a RINEX 2 navigation file: Klobuchar alpha/beta, UTC parameters, leap seconds."""

    alpha: tuple[float, float, float, float]
    beta: tuple[float, float, float, float]
    a0: float
    a1: float
    t_ot: int
    wn_t: int
    leap_seconds: int


def _floats(text: str) -> list[float]:
    text = text.replace("D", "E").replace("d", "e")
    out = []
    for k in range(0, len(text.rstrip()), 12):
        chunk = text[k : k + 12].strip()
        if chunk:
            out.append(float(chunk))
    return out


def read_header(path: str | Path) -> NavHeader:
    """Klobuchar and UTC parameters of a RINEX 2 GPS navigation file's header."""
    values: dict[str, str] = {}
    with open(path, encoding="ascii", errors="replace") as fh:
        for line in fh:
            label = line[60:].strip()
            if label == "END OF HEADER":
                break
            values[label] = line[:60]
    missing = [k for k in ("ION ALPHA", "ION BETA", "DELTA-UTC: A0,A1,T,W", "LEAP SECONDS") if k not in values]
    if missing:
        raise RinexFormatError(f"{path}: RINEX navigation header lacks {', '.join(missing)}; use the complete broadcast file")
    utc = values["DELTA-UTC: A0,A1,T,W"]
    label = "ION ALPHA"
    try:
        alpha = tuple(_floats(values[label][2:50]))
        label = "ION BETA"
        beta = tuple(_floats(values[label][2:50]))
        label = "DELTA-UTC: A0,A1,T,W"
        a0, a1 = float(utc[3:22].replace("D", "E")), float(utc[22:41].replace("D", "E"))
        t_ot, wn_t = int(utc[41:50]), int(utc[50:59])
        label = "LEAP SECONDS"
        leap_seconds = int(values[label][:6])
    except ValueError as exc:
        raise RinexFormatError(f"{path}: RINEX header line {label!r} is garbled ({one_line(exc)}); use an intact broadcast file") from None
    for label, numbers, count in (("ION ALPHA", alpha, 4), ("ION BETA", beta, 4), ("DELTA-UTC: A0,A1,T,W", (a0, a1), 2)):
        if len(numbers) != count or not all(np.isfinite(numbers)):
            raise RinexFormatError(f"{path}: RINEX header line {label!r} does not hold {count} finite numbers; use an intact broadcast file")
    return NavHeader(alpha=alpha, beta=beta, a0=a0, a1=a1, t_ot=t_ot, wn_t=wn_t, leap_seconds=leap_seconds)  # type: ignore[arg-type]


def seconds_of_week(times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(GPS week, seconds of week) of datetime64 GPS times."""
    elapsed = (np.asarray(times, dtype="datetime64[ns]") - GPS_EPOCH) / np.timedelta64(1, "s")
    week = np.floor(elapsed / SECONDS_PER_WEEK).astype(int)
    return week, elapsed - week * SECONDS_PER_WEEK


def load(path: str | Path) -> list[Ephemeris]:
    """Every GPS data set of a RINEX 2 navigation file, sorted by (PRN, t_oc)."""
    import georinex
    import pandas as pd

    path = Path(path)
    try:
        nav = georinex.load(path)
    except Exception as exc:  # georinex raises many types for a malformed file
        raise RinexFormatError(f"{path}: not a readable RINEX navigation file ({type(exc).__name__}: {one_line(exc)}); "
                               "use an intact RINEX 2 GPS broadcast file") from None
    if "sv" not in nav.coords or "time" not in nav.dims or any(name not in nav for name in _REQUIRED):
        raise RinexFormatError(f"{path}: not a RINEX 2 GPS navigation file (no satellite records with the broadcast fields); "
                               "use a GPS broadcast file (brdcDDD0.YYn)")
    out: list[Ephemeris] = []
    # one (time, sv) array per field, so that a satellite's records are a column of each: selecting and
    # dropping empty records per satellite with xarray (sel + dropna) costs ~0.4 s a file
    if any(set(nav[name].dims) != {"time", "sv"} for name in nav.data_vars):
        raise RinexFormatError(f"{path}: the navigation records do not form a (time, satellite) table; use an intact RINEX 2 GPS broadcast file")
    table = nav[list(nav.data_vars)].transpose("time", "sv")
    fields_tsv = {name: table[name].values for name in table.data_vars}
    times = table.time.values
    for j, sv in enumerate(table.sv.values):
        if not str(sv).startswith("G"):
            continue
        prn = int(str(sv)[1:]) if str(sv)[1:].isdigit() else -1
        if not 1 <= prn <= 32:
            raise RinexFormatError(f"{path}: a record names satellite {str(sv)!r}; GPS PRNs are G01..G32 (fix the record's PRN field)")
        held = np.zeros(times.size, dtype=bool)  # a record of this satellite at that time: any field not blank (dropna how="all")
        for values in fields_tsv.values():
            held |= pd.notna(values[:, j])
        columns = {name: values[held, j] for name, values in fields_tsv.items()}
        sat_times = times[held]
        week, sow = seconds_of_week(sat_times)
        for k in range(sat_times.size):
            rec = {name: float(column[k]) for name, column in columns.items()}
            blank = [name for name in _REQUIRED if not np.isfinite(rec[name])]
            if blank:
                raise RinexFormatError(f"{path}: the {sv} record of {str(sat_times[k])[:19]} has blank or unreadable {', '.join(blank)}; "
                                       "fix or drop that record")
            fields = {lnav_name: rec[rinex] * factor for rinex, (lnav_name, factor) in _RINEX_FIELDS.items()}
            fit_hours = rec.get("FitIntvl", 0.0)
            fields.update(
                wn=int(week[k]) % 1024,
                l2_code=int(rec["CodesL2"]),
                ura=ura_index(rec["SVacc"]),
                health=int(rec["health"]),
                iodc=int(rec["IODC"]),
                iode=int(rec["IODE"]),
                l2p_flag=int(rec["L2Pflag"]),
                t_oc=float(round(sow[k])),
                fit_flag=0 if fit_hours in (0.0, 4.0) or not np.isfinite(fit_hours) else 1,
                aodo=0,
            )
            for sf in (1, 2, 3):
                for name, f in lnav.FIELDS[sf].items():
                    try:
                        lnav.raw_value(fields[name], f, name)
                    except ValueError as exc:
                        raise RinexFormatError(f"{path}: the {sv} record of {str(sat_times[k])[:19]} cannot be broadcast ({one_line(exc)}); "
                                               "the record is garbled, fix or drop it") from None
            out.append(
                Ephemeris(
                    prn=prn, week=int(week[k]), transmit_time=rec["TransTime"],
                    fit_hours=fit_hours if np.isfinite(fit_hours) else 0.0, fields=fields,
                )
            )
    out.sort(key=lambda e: (e.prn, e.week, e.t_oc))
    if not out:
        raise RinexFormatError(f"{path}: no GPS navigation data sets found; use a GPS broadcast file (brdcDDD0.YYn)")
    return out


def by_prn(ephemerides: list[Ephemeris]) -> dict[int, list[Ephemeris]]:
    """Data sets grouped per PRN, each list in time order."""
    groups: dict[int, list[Ephemeris]] = {}
    for eph in ephemerides:
        groups.setdefault(eph.prn, []).append(eph)
    return groups
