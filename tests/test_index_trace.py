"""The real-index event: the run choice (scintrack.data.biscef.strongest_run) and its trace (scintrack.data.index_trace)."""

import numpy as np
import pytest
import xarray as xr
from scipy import signal

from scintrack.data.biscef import BiscefFormatError, strongest_run
from scintrack.data.index_trace import crossfade_weight, detrended_variance, index_trace, power_law_filter, strengths

TS = 0.001


def _rows(entries):
    """BiScEF-like rows: entries of (station, prn, minute, phi60, cn0); T 0.5, p 2.5, S4 0."""
    n = len(entries)
    t0 = np.datetime64("2023-01-15T10:00:12", "s")
    return xr.Dataset(
        {
            "station": ("row", np.array([e[0] for e in entries], dtype=object)),
            "prn": ("row", np.array([e[1] for e in entries])),
            "phi60": ("row", np.array([e[3] for e in entries], dtype=float)),
            "cn0": ("row", np.array([e[4] for e in entries], dtype=float)),
            "T": ("row", np.full(n, 0.5)), "p": ("row", np.full(n, 2.5)), "s4": ("row", np.zeros(n)), "elevation": ("row", np.full(n, 40.0)),
        },
        coords={"time": ("row", np.array([t0 + np.timedelta64(60 * e[2], "s") for e in entries]))},
    )


def test_the_run_is_chosen_by_its_median_not_by_one_spike():
    spike = [("TRO2", 5, m, 3.0 if m == 2 else 0.1, 40.0) for m in range(6)]  # one 3-rad minute, median 0.1
    steady = [("NYA2", 9, m, 0.5, 40.0) for m in range(6)]  # median 0.5
    run = strongest_run(_rows(spike + steady), 4)
    assert (run["station"], run["prn"], run["minutes"]) == ("NYA2", 9, 4)
    assert run["median_phi60"] == pytest.approx(0.5)
    assert len(run["phi60"]) == len(run["time_utc"]) == 4


def test_weak_minutes_and_gaps_break_a_run():
    weak = [("NYA2", 9, m, 0.9, 30.0 if m == 3 else 40.0) for m in range(6)]  # a 30 dB-Hz minute in the middle
    gap = [("TRO2", 5, m, 0.8, 40.0) for m in (0, 1, 2, 4, 5, 6)]  # minute 3 missing
    ok = [("TRO2", 7, m, 0.2, 40.0) for m in range(4)]
    run = strongest_run(_rows(weak + gap + ok), 4)
    assert (run["station"], run["prn"]) == ("TRO2", 7)
    with pytest.raises(BiscefFormatError, match="no run of 5 consecutive usable minutes"):
        strongest_run(_rows(ok), 5)


def test_crossfade_weights_sum_to_one_and_peak_at_their_minute():
    n, minutes = 5000, 5
    w = np.array([crossfade_weight(n, TS, minutes, k, minute_s=1.0) for k in range(minutes)])
    assert np.allclose(w.sum(axis=0), 1.0)
    centres = ((np.arange(minutes) + 0.5) / TS).astype(int)
    assert np.allclose(w[np.arange(minutes), centres], 1.0)


def test_the_shaping_filter_gives_the_one_sided_power_law():
    """Welch's one-sided density of shaped unit white noise is T f^-p (slope and level at 1 Hz within 10 %)."""
    n, T, p = 2**20, 0.02, 2.7
    white = np.random.default_rng(1).standard_normal(n)
    x = np.fft.irfft(np.fft.rfft(white) * power_law_filter(n, TS, T, p, 0.05), n=n)
    f, pxx = signal.welch(x, fs=1 / TS, nperseg=2**14)
    band = (f >= 0.5) & (f <= 20.0)
    slope, level = np.polyfit(np.log10(f[band]), np.log10(pxx[band]), 1)
    assert -slope == pytest.approx(p, abs=0.1)
    assert 10**level == pytest.approx(T, rel=0.1)


def test_strength_from_phi60_gives_that_sigma_phi():
    """With every minute alike, the rms of the trace's 60-s sigma_phi is the real Phi60 (within 10 %)."""
    minutes, phi = 6, 0.4
    run = {"minutes": minutes, "T": [1.0] * minutes, "p": [2.8] * minutes, "s4": [0.0] * minutes, "phi60": [phi] * minutes,
           "cn0": [40.0] * minutes, "time_utc": [f"m{k}" for k in range(minutes)], "station": "NYA2", "station_name": "Ny-Ålesund",
           "prn": 13, "start_utc": "2023-01-15T10:16:12", "median_phi60": phi}
    params = {"seed": 7, "name": "t", "ts": TS, "duration_s": 60.0 * minutes, "f_floor_hz": 0.05, "detrend_hz": 0.1, "strength": "phi60"}
    ds = index_trace(params, run)
    assert float(np.sqrt((ds["trace_phi60"] ** 2).mean())) == pytest.approx(phi, rel=0.1)
    assert np.all(ds["amplitude"].values == 1.0)  # S4 0: no amplitude scintillation
    assert ds.attrs["source"] == "surrogate" and "SURROGATE" in ds.attrs["title"] and "REAL" in ds.attrs["title"]
    # the T it chose integrates to Phi60^2 through the high-pass
    t = strengths(run, TS, 0.05, 0.1, "phi60")
    assert detrended_variance(TS, float(t[0]), 2.8, 0.05, 0.1) == pytest.approx(phi**2, rel=1e-9)
    assert np.array_equal(strengths(run, TS, 0.05, 0.1, "T"), np.ones(minutes))
    with pytest.raises(ValueError, match="strength must be"):
        strengths(run, TS, 0.05, 0.1, "S4")


def test_the_amplitude_has_the_minutes_s4():
    minutes, s4 = 4, 0.3
    run = {"minutes": minutes, "T": [1e-3] * minutes, "p": [2.5] * minutes, "s4": [s4] * minutes, "phi60": [0.1] * minutes,
           "cn0": [40.0] * minutes, "time_utc": [f"m{k}" for k in range(minutes)], "station": "TRO2", "station_name": "Tromsø",
           "prn": 5, "start_utc": "2023-01-15T10:00:12", "median_phi60": 0.1}
    params = {"seed": 3, "name": "a", "ts": TS, "duration_s": 60.0 * minutes, "f_floor_hz": 0.05, "detrend_hz": 0.1, "strength": "T"}
    ds = index_trace(params, run)
    assert float(ds["trace_s4"].mean()) == pytest.approx(s4, rel=0.15)
    assert float((ds["amplitude"] ** 2).mean()) == pytest.approx(1.0, rel=0.05)
    with pytest.raises(ValueError, match="shorter than the trace"):
        index_trace({**params, "duration_s": 60.0 * minutes + 1.0}, run)
