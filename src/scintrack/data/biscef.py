"""Real scintillation indices of Septentrio receivers in BiScEF files: the loader and the event choice.

BiScEF (Binary Scintillation Exchange Format, kartverket/BiScEF) is NetCDF4
with one row per satellite and minute along the dimension ``UNIXTime``.  The
project holds one day of it from two stations (``data/real/biscef/``, ``data/registry.yaml``):
Tromsø (TRO2, PolaRx5S) and Ny-Ålesund (NYA2, PolaRxS), 2023-01-15.
:func:`load` reads one file into a Dataset with one row per (GPS satellite,
minute) and the L1 C/A indices under the names the project uses:

* **constellation**: GPS only, the rows whose ``SVID`` is 1-37 (Septentrio's
  SVID numbering, which BiScEF keeps: 1-37 GPS PRN, 38-68 GLONASS, 71-106
  Galileo, ...); the PRN is the SVID.  Signal 1 (``s1``) is L1 C/A for GPS.
* **time**: UTC, from ``GPSWeek`` and ``TOW`` (GPS time) minus GPS-UTC, the
  leap seconds in force (18 s since 2017-01-01; the table is the package's
  :data:`~scintrack.signals.gps.lnav_pages.LEAP_SECOND_DATES`).  The
  ``UNIXTime`` axis of these files holds GPS time counted from 1970, not UTC,
  so it is not used.  A row's time is the receiver's time tag of its minute.
* **s4**: ``S4s1``, the S4 with the thermal-noise part removed.  The
  converter that wrote the files labels it "Total S4", its later version
  "Corrected S4"; the values settle it: ``S4s1`` is 0 in 99 % of the GPS rows
  and lies below the noise correction ``S4cors1`` in most of the others,
  which a total S4 (whose square is at least the noise part's square) cannot
  do.  So it is the corrected value, clipped at 0 where the correction
  exceeds the total, and is used as it is (no second subtraction);
  ``S4cors1`` is kept as ``s4_correction``.
* **phi60**: ``Phi60s1``, sigma_phi over 60 s of the carrier phase after the
  receiver's 0.1-Hz 6th-order Butterworth high-pass [rad].
* **T**, **p**: ``Ts1``, the phase PSD at 1 Hz [rad^2/Hz], and ``-ps1``: the
  files give the fitted slope of the 0.1-25 Hz phase spectrum with its sign
  (negative), the project writes the spectrum ``T f^-p`` (p > 0).
* **cn0**: ``AvgCN0s1``, mean C/N0 over the minute [dB-Hz].
* **elevation**, **azimuth** [deg] as given (NaN where the file has none:
  such a row is below any elevation mask).

Missing values: Septentrio writes -1 for an index it could not compute and 0
for a phase index, T, p or C/N0 that was not computed; both become NaN
(``S4s1`` = 0 stays 0: it is a value), and the noise correction of a row
without C/N0 is NaN.  A satellite listed twice in one minute (two channels,
one usually without lock) keeps the row with the higher C/N0; the count of
rows dropped so is in the attributes.

A file that is missing a variable, has one of the wrong shape or type, or is
not readable NetCDF raises :class:`BiscefFormatError`: one line naming the
file, the variable and the fix.

:func:`strongest_minute` makes the pre-declared event choice
(``docs/REPRODUCTION.md``, "Real index data"): the minute with the largest
L1 Phi60 of a GPS satellite at elevation >= :data:`ELEVATION_MIN_DEG`.

The constants and :func:`file_params` shape the workflow's params while
Snakemake builds its DAG, so xarray is imported inside the functions that
read files only.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import InputError

if TYPE_CHECKING:
    import numpy as np
    import xarray as xr

#: registry entry (``data/registry.yaml``) -> the file, relative to the project
FILES = {
    "real_biscef_nortro2_20230115": "data/real/biscef/NORTRO220230115.nc",
    "real_biscef_nornya2_20230115": "data/real/biscef/NORNYA220230115.nc",
}
#: receiver code (the files' ``ReceiverCode``) -> the station's name
STATION_NAMES = {"TRO2": "Tromsø", "NYA2": "Ny-Ålesund"}
#: the pre-declared elevation mask of the event choice [deg]
ELEVATION_MIN_DEG = 20.0
#: Septentrio SVIDs of GPS satellites (the PRN)
GPS_SVID = (1, 37)
#: the BiScEF variables read (signal 1 = L1 C/A for GPS)
VARIABLES = ("GPSWeek", "TOW", "SVID", "Elevation", "Azimuth", "AvgCN0s1", "S4s1", "S4cors1", "Phi60s1", "Ts1", "ps1")
SECONDS_PER_WEEK = 604800


class BiscefFormatError(InputError):
    """A BiScEF file that is unreadable or lacks a variable the loader needs."""


def station_name(code: str) -> str:
    return STATION_NAMES.get(code, code)


def file_params(registry: str | Path) -> dict[str, dict[str, str | None]]:
    """Registry entry -> {path, sha256 from ``registry``} of every file (what the workflow's result depends on)."""
    from .registry import expected_sha256

    return {name: {"path": path, "sha256": expected_sha256(registry, name)} for name, path in FILES.items()}


def check_sha256(path: str | Path, expected: str | None, entry: str) -> None:
    """Refuse a file whose sha256 is not the registry's (or that has no registry entry)."""
    from ..io import sha256_file

    if not expected:
        raise BiscefFormatError(f"{path}: no sha256 in data/registry.yaml under {entry}; add the entry (data/README.md says where the file comes from)")
    got = sha256_file(path)
    if got != expected:
        raise BiscefFormatError(f"{path}: sha256 {got[:12]}... is not the registry's {expected[:12]}... ({entry}); restore the file "
                                "from its source (data/README.md) or update data/registry.yaml")


def gps_minus_utc_s(t_gps: np.ndarray) -> np.ndarray:
    """GPS-UTC [s] at GPS times ``t_gps`` (datetime64): the leap seconds in force, from the package's table.

    Leap second ``k`` (1-based) takes effect at 00:00 UTC of its date, which is GPS time date + ``k`` s."""
    import numpy as np

    from ..signals.gps.lnav_pages import LEAP_SECOND_DATES

    starts = np.array([d.astype("datetime64[ns]") + np.timedelta64(k, "s") for k, d in enumerate(LEAP_SECOND_DATES, start=1)])
    return np.searchsorted(starts, np.asarray(t_gps, dtype="datetime64[ns]"), side="right").astype(np.int64)


def gps_to_utc(week, tow) -> np.ndarray:
    """UTC (datetime64[ns]) of GPS week ``week`` and second of week ``tow``: GPS time minus the leap seconds in force."""
    import numpy as np

    from ..signals.gps.ephemeris import GPS_EPOCH

    seconds = np.asarray(week, dtype=np.int64) * SECONDS_PER_WEEK + np.asarray(tow, dtype=np.float64)
    t_gps = GPS_EPOCH + np.round(seconds * 1e9).astype(np.int64).astype("timedelta64[ns]")
    return t_gps - gps_minus_utc_s(t_gps).astype("timedelta64[s]")


def _read(path: Path) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """The variables of :data:`VARIABLES` as 1-D arrays and the global attributes; one line on any defect."""
    import numpy as np
    import xarray as xr

    if not path.is_file():
        raise BiscefFormatError(f"{path}: no such file; restore it (data/README.md says where it comes from)")
    try:
        raw = xr.open_dataset(path, engine="netcdf4", decode_times=False, mask_and_scale=True)
    except (OSError, ValueError, RuntimeError, KeyError, IndexError) as exc:
        reason = " ".join(str(getattr(exc, "strerror", None) or exc).split())[:120]
        raise BiscefFormatError(f"{path}: not a readable NetCDF/BiScEF file ({reason}); it is truncated or corrupt: restore it from its source "
                                "(data/README.md)") from None
    with raw:
        out: dict[str, np.ndarray] = {}
        n = None
        for name in VARIABLES:
            if name not in raw.variables:
                raise BiscefFormatError(f"{path}: variable {name} is missing; a BiScEF file of a Septentrio receiver has it "
                                        "(format: kartverket/BiScEF FormatDescription.md); use a complete file")
            var = raw[name]
            if var.ndim != 1:
                raise BiscefFormatError(f"{path}: variable {name} has {var.ndim} dimensions, BiScEF data are 1-D along UNIXTime; use a BiScEF file")
            try:
                values = np.asarray(var.values)
            except (OSError, ValueError, RuntimeError) as exc:
                raise BiscefFormatError(f"{path}: variable {name} cannot be read ({' '.join(str(exc).split())[:80]}); the file is truncated "
                                        "or corrupt: restore it from its source (data/README.md)") from None
            if values.dtype.kind not in "iuf":
                raise BiscefFormatError(f"{path}: variable {name} is of type {values.dtype}, not numeric; use a BiScEF file")
            if n is not None and values.size != n:
                raise BiscefFormatError(f"{path}: variable {name} has {values.size} rows, {VARIABLES[0]} has {n}; the file is malformed, "
                                        "restore it from its source (data/README.md)")
            n = values.size
            out[name] = values
        attrs = dict(raw.attrs)
    return out, attrs


def _check_ranges(path: Path, v: Mapping[str, np.ndarray]) -> None:
    import numpy as np

    checks = (("TOW", lambda x: (x >= 0) & (x < SECONDS_PER_WEEK), "0 <= TOW < 604800"),
              ("GPSWeek", lambda x: x >= 0, "GPSWeek >= 0"),
              ("Elevation", lambda x: ~(np.abs(x) > 90), "-90 <= Elevation <= 90 (or missing)"))
    for name, ok, text in checks:
        bad = ~ok(np.asarray(v[name], dtype=float))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise BiscefFormatError(f"{path}: variable {name} is {v[name][k]} in row {k}, outside {text}; the file is malformed, "
                                    "restore it from its source (data/README.md)")


def _missing_as_nan(x: np.ndarray, *, zero: bool) -> np.ndarray:
    """Septentrio's "not computed" values as NaN: negative values, and 0 when ``zero``."""
    import numpy as np

    x = np.asarray(x, dtype=np.float64).copy()
    x[x < 0] = np.nan
    if zero:
        x[x == 0] = np.nan
    return x


def load(path: str | Path) -> xr.Dataset:
    """One BiScEF file as a Dataset with one row per (GPS satellite, minute), sorted by time and PRN (module docstring)."""
    import numpy as np
    import xarray as xr

    path = Path(path)
    v, attrs = _read(path)
    _check_ranges(path, v)
    svid = np.asarray(v["SVID"], dtype=np.int64)
    keep = (svid >= GPS_SVID[0]) & (svid <= GPS_SVID[1])
    cn0 = _missing_as_nan(v["AvgCN0s1"][keep], zero=True)
    s4_cor = _missing_as_nan(v["S4cors1"][keep], zero=False)
    s4_cor[~np.isfinite(cn0)] = np.nan
    p_signed = np.asarray(v["ps1"][keep], dtype=np.float64)
    p = np.where((p_signed < 0) & np.isfinite(p_signed), -p_signed, np.nan)
    time = gps_to_utc(v["GPSWeek"][keep], v["TOW"][keep])
    code = str(attrs.get("ReceiverCode", path.stem))
    columns = {
        "prn": svid[keep],
        "time": time,
        "elevation": np.asarray(v["Elevation"][keep], dtype=np.float64),
        "azimuth": np.asarray(v["Azimuth"][keep], dtype=np.float64),
        "s4": _missing_as_nan(v["S4s1"][keep], zero=False),
        "s4_correction": s4_cor,
        "phi60": _missing_as_nan(v["Phi60s1"][keep], zero=True),
        "T": _missing_as_nan(v["Ts1"][keep], zero=True),
        "p": p,
        "cn0": cn0,
    }
    order, dropped = _one_row_per_minute(columns["prn"], time, cn0)
    meta = {
        "prn": {"long_name": "GPS PRN (Septentrio SVID 1-37)", "units": "1"},
        "elevation": {"long_name": "satellite elevation", "units": "degree"},
        "azimuth": {"long_name": "satellite azimuth", "units": "degree"},
        "s4": {"long_name": "L1 C/A S4 over the minute, thermal-noise part removed (S4s1; 0 where the correction exceeds the total)", "units": "1"},
        "s4_correction": {"long_name": "thermal-noise part of the L1 C/A S4 (S4cors1)", "units": "1"},
        "phi60": {"long_name": "L1 C/A sigma_phi over 60 s after a 0.1-Hz 6th-order Butterworth high-pass (Phi60s1)", "units": "rad"},
        "T": {"long_name": "L1 C/A phase PSD at 1 Hz (Ts1)", "units": "rad2/Hz"},
        "p": {"long_name": "slope p of the L1 C/A phase PSD T f^-p over 0.1-25 Hz (-ps1)", "units": "1"},
        "cn0": {"long_name": "L1 C/A C/N0, mean over the minute (AvgCN0s1)", "units": "dB-Hz"},
    }
    data = {k: (("row",), columns[k][order], meta[k]) for k in meta}
    data["station"] = (("row",), np.full(order.size, code, dtype=object), {"long_name": "receiver code (BiScEF ReceiverCode)"})
    ds = xr.Dataset(data, coords={"time": (("row",), time[order], {"long_name": "UTC time tag of the minute (GPS week/TOW minus GPS-UTC)"})})
    ds.attrs.update({
        "source_file": path.name, "station": code, "station_name": station_name(code), "constellation": "GPS",
        "signal": "L1 C/A (BiScEF signal 1)", "receiver_type": str(attrs.get("ReceiverType", "")),
        "receiver_latitude_deg": float(attrs.get("ReceiverLatitude", np.nan)), "receiver_longitude_deg": float(attrs.get("ReceiverLongitude", np.nan)),
        "phase_high_pass": f"{attrs.get('PhaseHighPassFilterType', '')} {float(attrs.get('PhaseHighPassFilterFreqCutoff', np.nan)):g} Hz".strip(),
        "duplicate_rows_dropped": int(dropped),
    })
    return ds


def _one_row_per_minute(prn: np.ndarray, time: np.ndarray, cn0: np.ndarray) -> tuple[np.ndarray, int]:
    """Row order by (time, PRN), one row per (PRN, time): of repeated rows the one with the higher C/N0 (then the first)."""
    import numpy as np

    rank = np.where(np.isfinite(cn0), -cn0, np.inf)  # higher C/N0 first, missing last
    order = np.lexsort((np.arange(prn.size), rank, prn, time.astype(np.int64)))
    t, s = time[order].astype(np.int64), prn[order]
    first = np.ones(order.size, dtype=bool)
    first[1:] = (t[1:] != t[:-1]) | (s[1:] != s[:-1])
    return order[first], int((~first).sum())


def select(ds: xr.Dataset, elevation_min_deg: float = ELEVATION_MIN_DEG) -> xr.Dataset:
    """The rows at elevation >= ``elevation_min_deg``."""
    import numpy as np

    keep = np.asarray(ds["elevation"].values) >= elevation_min_deg
    out = ds.isel(row=np.flatnonzero(keep))
    out.attrs["elevation_min_deg"] = float(elevation_min_deg)
    return out


def combine(datasets: Iterable[xr.Dataset]) -> xr.Dataset:
    """Rows of several stations in one Dataset (stations in the given order); per-file attributes go under their station code."""
    import xarray as xr

    datasets = list(datasets)
    out = xr.concat(datasets, dim="row", data_vars="all", coords="all", compat="override", combine_attrs="drop")
    out.attrs["stations"] = ",".join(str(d.attrs["station"]) for d in datasets)
    for d in datasets:
        code = str(d.attrs["station"])
        for key in ("source_file", "station_name", "receiver_type", "receiver_latitude_deg", "receiver_longitude_deg", "duplicate_rows_dropped"):
            out.attrs[f"{code}_{key}"] = d.attrs[key]
    for key in ("constellation", "signal", "phase_high_pass", "elevation_min_deg"):
        values = {d.attrs.get(key) for d in datasets}
        if len(values) == 1:
            out.attrs[key] = values.pop()
    return out


def strongest_minute(ds: xr.Dataset) -> dict[str, Any]:
    """The row with the largest finite Phi60 (the earliest of equal ones): station, PRN, UTC time and its indices."""
    import numpy as np

    phi = np.asarray(ds["phi60"].values, dtype=float)
    if not np.isfinite(phi).any():
        raise BiscefFormatError("the BiScEF rows hold no Phi60 value at the elevation mask; the event cannot be chosen (check the files)")
    k = int(np.nanargmax(phi))
    row = ds.isel(row=k)
    code = str(row["station"].values)
    return {
        "row": k, "station": code, "station_name": station_name(code), "prn": int(row["prn"]),
        "time_utc": str(np.datetime_as_string(row["time"].values, unit="s")),
        **{key: float(row[key]) for key in ("elevation", "azimuth", "phi60", "s4", "s4_correction", "T", "p", "cn0")},
    }


#: the second, pre-declared event choice (docs/REPRODUCTION.md, "Real index event, second choice")
RUN_CN0_MIN_DBHZ = 35.0
RUN_VARIABLES = ("phi60", "s4", "T", "p", "cn0", "elevation")


def strongest_run(ds: xr.Dataset, minutes: int, cn0_min_dbhz: float = RUN_CN0_MIN_DBHZ) -> dict[str, Any]:
    """The run of ``minutes`` consecutive minutes of one satellite at one station with the largest median Phi60.

    A run's minutes are 60 s apart (one row each), every one with a finite
    Phi60, T, p and S4 and a C/N0 of at least ``cn0_min_dbhz``; the rows are
    those of ``ds`` (already at the elevation mask).  Of equal medians the
    earliest run wins.  Returns the station, PRN, first minute (UTC) and the
    run's per-minute values (lists, in time order) under :data:`RUN_VARIABLES`
    plus ``time_utc``.
    """
    import numpy as np

    if minutes < 1:
        raise ValueError(f"a run needs at least one minute, not {minutes}")
    station = np.asarray(ds["station"].values).astype(str)
    prn = np.asarray(ds["prn"].values)
    t = np.asarray(ds["time"].values).astype("datetime64[s]").astype(np.int64)
    values = {k: np.asarray(ds[k].values, dtype=float) for k in RUN_VARIABLES}
    usable = np.isfinite(values["phi60"]) & np.isfinite(values["T"]) & np.isfinite(values["p"]) & np.isfinite(values["s4"])
    usable &= np.nan_to_num(values["cn0"], nan=-np.inf) >= cn0_min_dbhz
    best: tuple[float, int, np.ndarray] | None = None
    for code in sorted(set(station)):
        for sv in np.unique(prn[station == code]):
            rows = np.flatnonzero((station == code) & (prn == sv))
            rows = rows[np.argsort(t[rows], kind="stable")]
            for i in range(rows.size - minutes + 1):
                run = rows[i:i + minutes]
                if not usable[run].all() or not np.all(np.diff(t[run]) == 60):
                    continue
                med = float(np.median(values["phi60"][run]))
                if best is None or med > best[0] or (med == best[0] and t[run[0]] < best[1]):
                    best = (med, int(t[run[0]]), run)
    if best is None:
        raise BiscefFormatError(f"no run of {minutes} consecutive usable minutes (C/N0 >= {cn0_min_dbhz:g} dB-Hz, Phi60, T, p, S4 given) "
                                "in the BiScEF rows; shorten the run or check the files")
    run = best[2]
    code = str(station[run[0]])
    return {
        "station": code, "station_name": station_name(code), "prn": int(prn[run[0]]), "minutes": int(minutes),
        "start_utc": str(np.datetime_as_string(np.asarray(ds["time"].values)[run[0]], unit="s")),
        "median_phi60": best[0], "cn0_min_dbhz": float(cn0_min_dbhz),
        "time_utc": [str(x) for x in np.datetime_as_string(np.asarray(ds["time"].values)[run], unit="s")],
        **{k: [float(x) for x in values[k][run]] for k in RUN_VARIABLES},
    }
