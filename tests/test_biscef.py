"""The real Septentrio index files (BiScEF): loader, GPS time, event choice, defects, and the real-vs-surrogate products."""

from __future__ import annotations

import shutil
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr
from conftest import REPO

from scintrack.data import biscef as B
from scintrack.errors import InputError
from scintrack.io import sha256_file

TRO, NYA = (REPO / path for path in B.FILES.values())


def _raw(path) -> xr.Dataset:
    with xr.open_dataset(path, engine="netcdf4", decode_times=False) as ds:
        return ds.load()


@pytest.fixture(scope="module")
def stations():
    return {"TRO2": B.load(TRO), "NYA2": B.load(NYA)}


@pytest.fixture(scope="module")
def rows(stations):
    """What the rule writes: both stations at the elevation mask, with the chosen event in the attributes."""
    ds = B.combine([B.select(stations["TRO2"]), B.select(stations["NYA2"])])
    ds.attrs.update({f"event_{k}": v for k, v in B.strongest_minute(ds).items()})
    return ds


def test_committed_files_match_the_registry():
    for entry, rel in B.FILES.items():
        B.check_sha256(REPO / rel, B.file_params(REPO / "data" / "registry.yaml")[entry]["sha256"], entry)


def test_loader_keeps_one_row_per_gps_satellite_minute_with_plausible_values(stations):
    # GPS rows of the files (SVID 1-37): 16,823 at Tromsø; 16,458 at Ny-Ålesund, of which 29 repeat a (PRN, minute)
    assert {code: ds.sizes["row"] for code, ds in stations.items()} == {"TRO2": 16823, "NYA2": 16429}
    assert stations["NYA2"].attrs["duplicate_rows_dropped"] == 29
    for ds in stations.values():
        prn, t = ds["prn"].values, ds["time"].values
        assert prn.min() >= 1 and prn.max() <= 37 and ds.attrs["constellation"] == "GPS"
        assert not np.any(np.diff(t.astype(np.int64)) < 0)  # sorted by time
        assert len(set(zip(prn.tolist(), t.astype(np.int64).tolist()))) == prn.size  # one row per satellite and minute
        assert np.all((t >= np.datetime64("2023-01-14T23:59")) & (t < np.datetime64("2023-01-16")))
        s4, phi, p, el = (ds[v].values for v in ("s4", "phi60", "p", "elevation"))
        assert np.nanmin(s4) >= 0 and np.nanmin(phi) > 0
        assert np.all(s4[el >= B.ELEVATION_MIN_DEG] < 1.5)  # low satellites (multipath, 20 dB-Hz) reach 1.6
        finite_p = p[np.isfinite(p)]
        assert finite_p.size > 10000 and np.all((finite_p > 0) & (finite_p < 6))
        assert np.all((el[np.isfinite(el)] >= 0) & (el[np.isfinite(el)] <= 90))
        assert np.isfinite(phi).mean() > 0.7 and np.isfinite(s4).mean() > 0.99


def test_a_repeated_satellite_minute_keeps_the_row_with_the_higher_cn0(stations):
    raw = _raw(NYA)
    gps = raw["SVID"].values <= 37
    key = raw["SVID"].values.astype(np.int64) * 10**7 + raw["TOW"].values
    values, counts = np.unique(key[gps], return_counts=True)
    repeated = values[counts > 1]
    assert repeated.size == 29
    ds = stations["NYA2"]
    tow = (((ds["time"].values - np.datetime64("1980-01-06")) // np.timedelta64(1, "s")).astype(np.int64) + 18) % B.SECONDS_PER_WEEK
    kept = dict(zip((ds["prn"].values.astype(np.int64) * 10**7 + tow).tolist(), ds["cn0"].values.tolist()))
    for k in repeated:
        cn0 = raw["AvgCN0s1"].values[gps & (key == k)].astype(float)
        assert kept[int(k)] == pytest.approx(cn0.max())


def test_loader_takes_s4_as_given_and_turns_the_slope_sign(stations):
    raw = _raw(TRO)
    gps = (raw["SVID"].values >= 1) & (raw["SVID"].values <= 37)
    key = {(int(s), int(w) * B.SECONDS_PER_WEEK + int(tow)): i for i, (s, w, tow) in
           enumerate(zip(raw["SVID"].values, raw["GPSWeek"].values, raw["TOW"].values)) if gps[i]}
    ds = stations["TRO2"]
    gps_s = ((ds["time"].values - np.datetime64("1980-01-06")) // np.timedelta64(1, "s")).astype(np.int64) + 18
    idx = np.array([key[(int(s), int(g))] for s, g in zip(ds["prn"].values, gps_s)])
    s4_raw, ps_raw = raw["S4s1"].values[idx].astype(float), raw["ps1"].values[idx].astype(float)
    ok = s4_raw >= 0
    assert np.array_equal(ds["s4"].values[ok], s4_raw[ok])  # the corrected S4: no second subtraction of S4cors1
    assert (ds["s4"].values == 0).mean() > 0.98  # 0 in quiet minutes: the correction exceeds the total
    fit = ps_raw < 0
    assert np.allclose(ds["p"].values[fit], -ps_raw[fit]) and np.all(np.isnan(ds["p"].values[~fit]))
    # the files' UNIXTime axis is GPS time: UTC + 18 s on every row
    assert np.array_equal(raw["UNIXTime"].values[idx], (ds["time"].values.astype("datetime64[s]").astype(np.int64) + 18))


def test_gps_time_to_utc_at_known_instants():
    # GPS week 2245 starts 2023-01-15 00:00:00 GPS = 2023-01-14 23:59:42 UTC (GPS-UTC = 18 s since 2017)
    assert B.gps_to_utc(2245, 0) == np.datetime64("2023-01-14T23:59:42")
    assert B.gps_to_utc(2245, 6570) == np.datetime64("2023-01-15T01:49:12")
    # GPS week 1865 (2015-10-04) had 17 s; the 2017-01-01 leap second switches to 18 s exactly at 00:00 UTC
    assert B.gps_to_utc(1865, 0) == np.datetime64("2015-10-03T23:59:43")
    start_2017 = (np.datetime64("2017-01-01T00:00:18") - np.datetime64("1980-01-06")) // np.timedelta64(1, "s")
    week, tow = divmod(int(start_2017), B.SECONDS_PER_WEEK)
    assert B.gps_to_utc(week, tow) == np.datetime64("2017-01-01T00:00:00")
    assert B.gps_to_utc(week, tow - 2) == np.datetime64("2016-12-31T23:59:59")


def test_event_is_the_largest_phi60_at_the_mask_over_both_files(rows):
    ev = {k.removeprefix("event_"): v for k, v in rows.attrs.items() if k.startswith("event_")}
    best = []  # the same choice from the raw files, independently
    for path, code in ((TRO, "TRO2"), (NYA, "NYA2")):
        raw = _raw(path)
        phi = raw["Phi60s1"].values.astype(float)
        ok = (raw["SVID"].values <= 37) & (raw["Elevation"].values >= 20) & (phi > 0)
        k = int(np.argmax(np.where(ok, phi, -np.inf)))
        best.append((phi[k], code, int(raw["SVID"].values[k]), int(raw["TOW"].values[k]), float(raw["Ts1"].values[k])))
    phi, code, prn, tow, T = max(best)
    assert (ev["station"], ev["prn"], ev["phi60"], ev["T"]) == (code, prn, pytest.approx(phi), pytest.approx(T))
    assert ev["time_utc"] == str(B.gps_to_utc(2245, tow).astype("datetime64[s]"))
    assert (ev["station"], ev["prn"], ev["time_utc"]) == ("TRO2", 32, "2023-01-15T01:49:12")
    assert ev["elevation"] >= 20 and rows["elevation"].values.min() >= 20
    assert ev["phi60"] == np.nanmax(rows["phi60"].values)


def _one_line(exc: pytest.ExceptionInfo, *words: str) -> None:
    text = str(exc.value)
    assert "\n" not in text and all(w in text for w in words), text
    assert isinstance(exc.value, InputError)


def test_a_file_without_a_variable_names_the_file_and_the_variable(tmp_path):
    bad = tmp_path / "dropped.nc"
    _raw(TRO).isel(UNIXTime=slice(0, 300)).drop_vars("Phi60s1").to_netcdf(bad)
    with pytest.raises(B.BiscefFormatError) as exc:
        B.load(bad)
    _one_line(exc, str(bad), "Phi60s1", "missing")


def test_a_truncated_file_names_the_file(tmp_path):
    bad = tmp_path / "truncated.nc"
    data = TRO.read_bytes()
    bad.write_bytes(data[: len(data) // 2])
    with pytest.raises(B.BiscefFormatError) as exc:
        B.load(bad)
    _one_line(exc, str(bad), "truncated or corrupt")


def test_a_changed_file_is_refused_against_the_registry(tmp_path):
    copy = tmp_path / TRO.name
    shutil.copy(TRO, copy)
    want = sha256_file(TRO)
    B.check_sha256(copy, want, "real_biscef_nortro2_20230115")
    with open(copy, "ab") as fh:
        fh.write(b"\0")
    with pytest.raises(B.BiscefFormatError) as exc:
        B.check_sha256(copy, want, "real_biscef_nortro2_20230115")
    _one_line(exc, str(copy), "registry", "real_biscef_nortro2_20230115")


def test_a_script_reports_a_malformed_file_as_one_error_line(tmp_path):
    bad = tmp_path / "dropped.nc"
    _raw(NYA).isel(UNIXTime=slice(0, 50)).drop_vars("Ts1").to_netcdf(bad)
    code = ("from scintrack.errors import install_script_hook\ninstall_script_hook()\n"
            f"from scintrack.data.biscef import load\nload({str(bad)!r})\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and str(bad) in lines[0] and "Ts1" in lines[0], proc.stderr


def _scenario(name: str, phi: list[float], source: str = "surrogate") -> xr.Dataset:
    """A Susi indices result with two 60-s windows; T and p of 3-s fits every second (T = the time, p = 2 + time / 100)."""
    t = np.arange(1.0, 121.0)
    return xr.Dataset({"phi60_true": ("window", phi), "s4_true": ("window", [0.1, 0.12]), "T_true": ("tp_time", t),
                       "p_true": ("tp_time", 2 + t / 100)}, coords={"window": [30.0, 90.0], "tp_time": t},
                      attrs={"scenario": name, "window_s": 60.0, "trace_source": source})


def test_scenario_minutes_are_the_windows_values_and_the_medians_of_their_fits():
    from scintrack.products.tables.susi_2014 import scenario_minutes

    m = scenario_minutes(_scenario("susi_high_latitude", [1.3, 1.5]))
    assert np.allclose(m["phi60"], [1.3, 1.5]) and np.allclose(m["s4"], [0.1, 0.12])
    assert np.allclose(m["T"], [30.5, 90.5])  # fits ending in (0, 60] and (60, 120]
    assert np.allclose(m["p"], [2.305, 2.905])


def test_real_table_and_figure_on_the_committed_files(rows):
    from scintrack.products.figure_check import check_figure
    from scintrack.products.figures.susi_2014 import exceedance, real_indices_verdict, susi_real_indices
    from scintrack.products.tables.susi_2014 import susi_table_real_indices

    x, y = exceedance(np.array([3.0, 1.0, 2.0, 2.0]))
    assert np.array_equal(x, [1, 2, 2, 3]) and np.allclose(y, [1, 0.75, 0.5, 0.25])
    scenarios = [_scenario("susi_high_latitude", [1.3, 1.5]), _scenario("susi_equatorial", [0.7, 0.8])]
    tables = susi_table_real_indices(rows, *scenarios)
    long = tables["table_real_indices_vs_surrogate_long"][0]
    tro = long[(long["source"] == "Tromsø (TRO2)") & (long["index"] == "Phi60 [rad]")].iloc[0]
    phi = rows["phi60"].values[(rows["station"].values.astype(str) == "TRO2") & np.isfinite(rows["phi60"].values)]
    assert tro["count"] == phi.size and tro["p99"] == pytest.approx(np.percentile(phi, 99)) and tro["max"] == pytest.approx(phi.max())
    high = long[long["source"].str.startswith("high-latitude") & (long["index"] == "Phi60 [rad]")].iloc[0]
    assert (high["data"], high["min"], high["max"]) == ("SURROGATE", 1.3, 1.5)
    event = tables["table_real_event"][0].iloc[0]
    assert (event["GPS PRN"], event["UTC"]) == (32, "2023-01-15T01:49:12")
    fig = susi_real_indices(rows, *scenarios)
    assert check_figure(fig) == []
    title = fig._suptitle.get_text()
    assert "Real" in title and "SURROGATE" in title
    verdict = real_indices_verdict(rows, *scenarios)
    assert verdict.status == "no paper figure" and "2.84 rad" in verdict.text
