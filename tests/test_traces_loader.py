"""The real-trace loader: round trips through every container, one clear error per defect."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from scintrack.data.traces import TraceFormatError, load_trace

BANDS = ["L1", "L2"]
TS = 0.01


def _arrays(n=2000, seed=0):
    rng = np.random.default_rng(seed)
    t = 1000.0 + np.arange(n) * TS
    out = {"time": t}
    for b in BANDS:
        a = np.abs(1 + 0.3 * rng.standard_normal(n))
        out[f"amplitude_{b}"] = a / np.sqrt(np.mean(a**2))
        out[f"phase_{b}"] = np.cumsum(0.05 * rng.standard_normal(n))
    return out


def _write(arrays, path, units=None):
    if path.suffix == ".npz":
        np.savez(path, **arrays)
    elif path.suffix == ".csv":
        import pandas as pd

        pd.DataFrame(arrays).to_csv(path, index=False)
    elif path.suffix == ".mat":
        from scipy.io import savemat

        savemat(path, arrays)
    else:
        ds = xr.Dataset({k: ("n", v) for k, v in arrays.items()})
        for k, u in (units or {}).items():
            ds[k].attrs["units"] = u
        ds.to_netcdf(path)
    return path


@pytest.mark.parametrize("suffix", [".nc", ".npz", ".csv", ".mat"])
def test_round_trip_every_container(tmp_path, suffix):
    arrays = _arrays()
    ds = load_trace(_write(arrays, tmp_path / f"e{suffix}", {"time": "s", "phase_L1": "rad"}), BANDS, TS, event="e1", source="real")
    assert ds["amplitude"].dims == ("band", "time")
    np.testing.assert_allclose(ds["amplitude"].sel(band="L2").values, arrays["amplitude_L2"], rtol=1e-12)
    np.testing.assert_allclose(ds["phase"].sel(band="L1").values, arrays["phase_L1"], rtol=1e-12)
    assert ds["time"].values[0] == 0.0 and ds.attrs["source"] == "real"


def _defect(name):
    a = _arrays()
    if name == "non_monotonic":
        a["time"][500], a["time"][501] = a["time"][501], a["time"][500]
    elif name == "nan":
        a["phase_L2"][300] = np.nan
    elif name == "length":
        a["amplitude_L1"] = a["amplitude_L1"][:-5]
    elif name == "db":
        a["amplitude_L1"] = 20 * np.log10(a["amplitude_L1"])
    elif name == "not_normalised":
        a["amplitude_L1"] = 30.0 * a["amplitude_L1"]
    elif name == "wrapped":
        a["phase_L1"] = np.angle(np.exp(1j * 40 * a["phase_L1"]))
    elif name == "milliseconds":
        a["time"] = a["time"] * 1000.0
    elif name == "missing":
        del a["phase_L2"]
    return a


@pytest.mark.parametrize(
    "name, message",
    [
        ("non_monotonic", "not strictly increasing at index 501"),
        ("nan", "'phase_L2' has a non-finite value .* at index 300"),
        ("length", "'amplitude_L1' has 1995 samples but 'time' has 2000"),
        ("db", "negative values: is it in dB"),
        ("not_normalised", "normalise the amplitude to unit mean power"),
        ("wrapped", "is it wrapped or in degrees"),
        ("milliseconds", "time must be in seconds"),
        ("missing", "variable 'phase_L2' is missing"),
    ],
)
def test_each_defect_has_its_own_error(tmp_path, name, message):
    path = _write(_defect(name), tmp_path / "bad.npz")
    with pytest.raises(TraceFormatError, match=message) as info:
        load_trace(path, BANDS, TS, event="e1", source="real")
    text = str(info.value)
    assert str(path) in text and "\n" not in text


def test_declared_wrong_units_are_rejected(tmp_path):
    path = _write(_arrays(), tmp_path / "deg.nc", {"phase_L1": "deg"})
    with pytest.raises(TraceFormatError, match="'phase_L1' has units 'deg'; expected 'rad'"):
        load_trace(path, BANDS, TS, event="e1", source="real")


def test_unknown_container_and_corrupt_file(tmp_path):
    with pytest.raises(TraceFormatError, match="unknown trace container"):
        load_trace(tmp_path / "x.h5", BANDS, TS, event="e1", source="real")
    good = _write(_arrays(), tmp_path / "whole.nc")
    bad = tmp_path / "cut.nc"
    bad.write_bytes(good.read_bytes()[: good.stat().st_size // 2])  # a truncated transfer
    with pytest.raises(TraceFormatError, match="cannot be read"):
        load_trace(bad, BANDS, TS, event="e1", source="real")
