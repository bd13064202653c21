"""The Zhao et al. receiver figures on a small made-up result: lock marked, conventions kept, verdicts computed.

The figures of ``scintrack.products.figures.zhao_receiver`` are drawn from a
tiny receiver result built here (two satellites, three trials, a PLL that runs
away after the onset and MM filters that keep lock), so the test needs no
pipeline run; every figure must pass the layout check and every verdict must
carry a status and its number.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from scintrack.products.figure_check import check_figure
from scintrack.products.figures import zhao_receiver as zr
from scintrack.products.figures.conventions import NO_LOCK_RMSE_2PI, NO_LOCK_RMSE_PI
from scintrack.products.registry import VERDICT_STATUSES

TRACKERS = ["pll", "mm_none", "mm_mask", "mm_iode"]
ONSET = 4.0
LOCK = {"threshold_rad": 0.5, "window_s": 1.0}


def _receiver(seed: int = 0) -> xr.Dataset:
    rng = np.random.default_rng(seed)
    n_tr, n_prn, n_trial = len(TRACKERS), 2, 3
    t_bit = np.arange(400) * 0.02 + 0.01
    t = np.arange(1.0, 8.0)
    jam = t_bit >= ONSET
    phase = 0.03 * rng.standard_normal((n_tr, n_prn, t_bit.size))
    phase[0][:, jam] = rng.uniform(-np.pi / 2, np.pi / 2, (n_prn, int(jam.sum())))  # PLL: uniform modulo pi
    freq = 0.1 * rng.standard_normal((n_tr, n_prn, t_bit.size))
    freq[0][:, jam] = -400.0 * (t_bit[jam] - ONSET) ** 2  # PLL runs away
    sv = (n_tr, n_prn, n_trial)
    data = {
        "enu_error": (("tracker", "trial", "time", "axis"), rng.standard_normal((n_tr, n_trial, t.size, 3))),
        "example_phase": (("tracker", "prn", "time_bit"), phase),
        "example_frequency": (("tracker", "prn", "time_bit"), freq),
        "sv_phase_rmse_jammed": (("tracker", "prn", "trial"), np.where(np.arange(n_tr)[:, None, None] == 0, NO_LOCK_RMSE_PI, 0.2) * np.ones(sv)),
        "sv_phase_rmse_clean": (("tracker", "prn", "trial"), np.full(sv, 0.05)),
        "sv_freq_var_jammed": (("tracker", "prn", "trial"), np.where(np.arange(n_tr)[:, None, None] == 0, 1e6, 1e-3) * np.ones(sv)),
        "sv_freq_var_clean": (("tracker", "prn", "trial"), np.full(sv, 0.03)),
        "sv_in_lock_jammed": (("tracker", "prn", "trial"), np.where(np.arange(n_tr)[:, None, None] == 0, 0.01, 0.99) * np.ones(sv)),
        "sv_bit_error_jammed": (("tracker", "prn", "trial"), np.full(sv, 0.05)),
        "prediction_next": (("word", "bit_in_word"), rng.integers(-1, 2, (50, 30)).astype(np.int8)),
        "prediction_last": (("word", "bit_in_word"), rng.choice([-1, 1], (50, 30)).astype(np.int8)),
    }
    for seg in ("clean", "jammed"):
        data[f"enu_mean_{seg}"] = (("tracker", "trial", "axis"), rng.standard_normal((n_tr, n_trial, 3)))
        data[f"enu_std_{seg}"] = (("tracker", "trial", "axis"), 1.0 + rng.random((n_tr, n_trial, 3)))
        data[f"err3d_rms_{seg}"] = (("tracker", "trial"), 2.0 + rng.random((n_tr, n_trial)))
    res = xr.Dataset(data, coords={"tracker": TRACKERS, "trial": np.arange(n_trial), "time": t, "axis": ["east", "north", "up"],
                                   "prn": [1, 11], "time_bit": t_bit})
    res.attrs.update(jammer_onset_s=ONSET, cn0_jammed_dbhz=15.0, n_trials=n_trial, figure_trial=0, uploads="PRN 11 at 6 s",
                     prediction_map_prn=1)
    return res


def _dataset() -> xr.Dataset:
    rt = np.arange(8000) * 1e-3
    return xr.Dataset({"receive_time": (("sv", "epoch"), np.stack([rt, rt])), "doppler": (("sv", "epoch"), np.stack([3400 + rt, 2100 - rt]))},
                      coords={"prn": ("sv", [1, 11])})


def test_lock_detector_is_a_running_mean_of_the_error_against_its_threshold():
    from scintrack.experiments import gps_prompts
    from scintrack.experiments.lock_detector import lock_state

    assert gps_prompts.lock_state is lock_state  # one detector for the receiver and its figures
    err = np.r_[np.full(100, 0.1), np.full(100, 1.0)]  # 20-ms epochs: 2 s in lock, then 2 s far off
    locked = lock_state(err, 0.02, 0.5, 1.0)  # 1-s window = 50 epochs: the mean crosses 0.5 after 22 bad epochs
    assert locked[:122].all() and not locked[122:].any()


def test_no_lock_levels_follow_the_wrapping_of_each_tracker():
    assert zr.no_lock_rmse("pll") == NO_LOCK_RMSE_PI and zr.no_lock_rmse("mm_iode") == NO_LOCK_RMSE_2PI


@pytest.mark.parametrize("name", ["zhao_fig06", "zhao_fig09"])
def test_pll_figures_cut_the_runaway_and_pass_the_layout_check(name):
    fig = getattr(zr, name)(_receiver(), _dataset(), lock=LOCK)
    assert check_figure(fig) == []
    freq_axes = fig.axes[1:3]
    for ax in freq_axes:  # no drawn frequency beyond the lock bound (+ the true Doppler on the middle panel)
        for line in ax.get_lines():
            y = np.asarray(line.get_ydata(), dtype=float)
            if line.get_color() == "tab:orange" and ax is fig.axes[2]:
                assert np.nanmax(np.abs(y)) <= zr.FREQ_LOCK_HZ + 1e-9
    text = " ".join(t.get_text() for ax in fig.axes for t in ax.texts)
    assert ("loop ran away" in text) == (name == "zhao_fig09")
    assert "SYNTHETIC SKYDEL-like data" in fig.texts[0].get_text()


@pytest.mark.parametrize("name", ["zhao_fig04", "zhao_fig07", "zhao_fig10", "zhao_fig11", "zhao_ablation"])
def test_receiver_figures_pass_the_layout_check(name):
    kwargs = {"lock": LOCK} if name == "zhao_fig10" else {}
    assert check_figure(getattr(zr, name)(_receiver(), **kwargs)) == []


def test_verdicts_carry_a_status_and_a_number():
    res, ds = _receiver(), _dataset()
    verdicts = [zr.verdict_fig06(res, ds, lock=LOCK), zr.verdict_fig09(res, ds, lock=LOCK), zr.verdict_fig10(res, lock=LOCK),
                zr.verdict_fig07(res), zr.verdict_fig11(res), zr.verdict_fig04(res), zr.verdict_ablation(res)]
    for v in verdicts:
        assert v.status in VERDICT_STATUSES and any(ch.isdigit() for ch in v.text)
    assert verdicts[1].status == "differs"  # lost lock, but the frequency ran away (std 1000 Hz, not the paper's 20 Hz)
    assert verdicts[2].status == "differs"  # in lock, frequency std 0.03 Hz, not 3 Hz


def test_representative_trial_is_the_median_one():
    res = _receiver()
    rms = res["err3d_rms_jammed"].sel(tracker="mm_iode").values
    assert rms[zr.representative_trial(res, "mm_iode", "jammed")] == np.sort(rms)[1]


def test_sweep_normalises_each_rmse_by_its_own_no_lock_level():
    points = []
    for cn0, pll_lock in ((15.0, 0.01), (30.0, 1.0)):
        shape = (len(TRACKERS), 2, 3)
        rmse = np.where(np.arange(len(TRACKERS))[:, None, None] == 0, NO_LOCK_RMSE_PI if pll_lock < 0.5 else 0.1, 0.2) * np.ones(shape)
        lock = np.where(np.arange(len(TRACKERS))[:, None, None] == 0, pll_lock, 1.0) * np.ones(shape)
        p = xr.Dataset({"phase_rmse_jammed": (("tracker", "prn", "trial"), rmse), "in_lock_jammed": (("tracker", "prn", "trial"), lock),
                        "bit_error_jammed": (("tracker", "prn", "trial"), np.zeros(shape)), "lol_events": (("tracker", "prn", "trial"), np.zeros(shape)),
                        "freq_var_jammed": (("tracker", "prn", "trial"), np.full(shape, 4.0))},
                       coords={"tracker": TRACKERS, "prn": [1, 11], "trial": np.arange(3)})
        p.attrs.update(cn0_jammed_dbhz=cn0, n_trials=3)
        points.append(p)
    fig = zr.zhao_sweep(*points)
    assert check_figure(fig) == []
    pll_y = [c for c in fig.axes[0].containers][0].lines[0].get_ydata()
    np.testing.assert_allclose(pll_y[0], 1.0)  # the lost PLL sits on the no-lock level, not below the MM filter
    v = zr.verdict_sweep(*points)
    assert v.status == "no paper figure" and "pll >= 30 dB-Hz" in v.text
