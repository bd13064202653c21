"""``scintrack.rundiff``: summary statistics against the old intervals, trials moved per tracker."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from scintrack import rundiff


def _result(rmse, lo, hi, ms, slips) -> xr.Dataset:
    trackers, trials, time = ["a", "b"], np.arange(3), np.arange(4) * 0.01
    return xr.Dataset(
        {
            "steady_rmse": ("tracker", np.asarray(rmse, float)),
            "steady_rmse_lo": ("tracker", np.asarray(lo, float)),
            "steady_rmse_hi": ("tracker", np.asarray(hi, float)),
            "rmse": (("tracker", "time"), np.full((2, 4), 9.0) if rmse[0] < 5 else np.zeros((2, 4))),  # a time series: not compared
            "rmse_lo": (("tracker", "time"), np.zeros((2, 4))),
            "rmse_hi": (("tracker", "time"), np.ones((2, 4))),
            "ms_steady": (("tracker", "trial"), np.asarray(ms, float)),
            "slips": (("tracker", "trial"), np.asarray(slips, np.int64)),
        },
        coords={"tracker": trackers, "trial": trials, "time": time},
    )


@pytest.fixture
def runs(tmp_path):
    old, new = tmp_path / "old", tmp_path / "new"
    for run in (old, new):
        (run / "results" / "experiments" / "x").mkdir(parents=True)
    ms = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    _result([1.0, 2.0], [0.8, 1.9], [1.2, 2.1], ms, [[0, 1, 2], [3, 4, 5]]).to_netcdf(old / "results" / "experiments" / "x" / "s.nc")
    ms_new = ms.copy()
    ms_new[0, 1] *= 1 + 1e-12  # rounding: not a moved trial
    ms_new[1, 2] *= 1 + 1e-3  # a moved trial
    _result([1.1, 2.3], [0.9, 2.2], [1.3, 2.4], ms_new, [[0, 1, 2], [3, 4, 6]]).to_netcdf(new / "results" / "experiments" / "x" / "s.nc")
    (old / "results" / "only_old.nc").write_bytes(b"")
    return old, new


def test_intervals_and_trials(runs):
    old, new = runs
    pairs, only = rundiff.result_pairs(old, new)
    assert [p[0] for p in pairs] == ["results/experiments/x/s.nc"] and only == ["results/only_old.nc"]
    iv = rundiff.interval_report(pairs)
    assert iv.count == 2 and iv.outside == 1  # b: 2.3 is outside [1.9, 2.1]; a: 1.1 is inside [0.8, 1.2]
    r, name, var, x, y = iv.largest[0]
    assert var == "steady_rmse" and (x, y) == (2.0, 2.3) and r == pytest.approx(0.3 / 0.1)
    assert len(iv.largest) == 1  # the largest change of each variable of each file
    rep = rundiff.tracker_report(pairs, rtol=1e-9)
    assert (rep["a"].trials, rep["a"].moved, rep["a"].slip_counts_changed) == (3, 0, 0)
    assert (rep["b"].trials, rep["b"].moved, rep["b"].slip_counts_changed) == (3, 1, 1)
    assert rundiff.tracker_report(pairs, rtol=1e-13)["a"].moved == 1


def test_main_prints_and_refuses_a_folder_without_results(runs, tmp_path, capsys):
    old, new = runs
    assert rundiff.main([str(old), str(new)]) == 0
    text = capsys.readouterr().out
    assert "new value outside the old interval: 1" in text and "1 /      3 trials moved" in text
    with pytest.raises(SystemExit) as exc:
        rundiff.main([str(tmp_path), str(new)])
    assert exc.value.code == 2
    assert "no results/ folder" in capsys.readouterr().err
