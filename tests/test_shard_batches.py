"""A shard simulated and tracked in batches of trials gives the same bits as in one batch.

:func:`scintrack.experiments.runner.run_shard` bounds a job's memory by simulating and tracking at most
``batch_trial_epochs`` trial-epochs at once.  Every variable of the result (per-trial statistics, sums over
trials, the on-line S4 statistics with not-estimable epochs, the SAKF monitors and their median, the examples of
the first trial) must not depend on the batching: compared here as raw bytes, for every tracker type, on a
two-segment CSM profile and on the AR world, with 40 trials as one batch and as batches of 32 + 8.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import REPO
from test_stress_sweep import _lut

from scintrack.batching import trial_batches, trials_held
from scintrack.config import load_config
from scintrack.experiments.runner import RowSum, S4Statistics, run_shard, s4_statistics

TRACKERS = ["pll", "kf", "akf", "akf_ar", "aekf_ar", "aekf_ar_fold", "susi_pll", "susi_akf", "susi_sakf", "zhao_mm"]


@pytest.fixture(scope="module")
def config():
    return load_config([REPO / "config" / "config.yaml"])


def _kwargs(config, scenario):
    tracking = dict(config["tracking"], steady_state_start_s=2.0, jitter_window_s=1.0, s4_window=200, s4_min_epochs=100, adapt_hold=50,
                    adaptation_points=[[0.5, 0.4], [0.9, 0.05]])
    return dict(scenario_name="batches", scenario=scenario, tracker_names=TRACKERS, tracker_specs=config["trackers"], tracking=tracking,
                lut=_lut(), seed=11, ts=0.01, nspa=4, warmup_s=1.0, trials=range(3, 43))


def _same(a, b):
    assert list(a.data_vars) == list(b.data_vars)
    for name in a.data_vars:
        assert a[name].dims == b[name].dims, name
        assert a[name].values.tobytes() == b[name].values.tobytes(), f"{name} differs between batchings"
    for name in a.coords:
        assert a[name].values.tobytes() == b[name].values.tobytes(), name
    assert a.attrs == b.attrs


@pytest.mark.parametrize("scenario", [
    {"duration_s": 6.0, "cn0_dbhz": 28.0, "segments": [{"start_s": 0.0, "s4": 0.9, "tau0": 0.1}, {"start_s": 3.0, "s4": 0.5, "tau0": 0.4}]},
    {"duration_s": 6.0, "cn0_dbhz": 35.0, "scintillation_model": "ar", "segments": [{"start_s": 0.0, "s4": 0.9, "tau0": 0.05}]},
], ids=["csm_profile", "ar_world"])
def test_batching_does_not_change_a_bit(config, scenario):
    kw = _kwargs(config, scenario)
    whole = run_shard(**kw, batch_trial_epochs=10**12)
    assert trial_batches(40, 600, 1) == [(0, 32), (32, 40)]
    batched = run_shard(**kw, batch_trial_epochs=1)
    _same(whole, batched)
    # the example trial and the monitors are real content, not NaN placeholders
    assert np.isfinite(whole["T_mean"].sel(tracker="susi_sakf").values[-10:]).all()
    assert np.isfinite(whole["s4_hat_mean"].sel(tracker="aekf_ar").values[-10:]).all()


def test_trial_batches_are_whole_lane_blocks_within_the_budget():
    assert trial_batches(100, 50_000, 2_000_000) == [(0, 32), (32, 64), (64, 96), (96, 100)]
    assert trial_batches(25, 300_000, 2_000_000) == [(0, 25)]  # never below one lane block
    assert trial_batches(100, 6_000, 2_000_000) == [(0, 100)]
    assert trial_batches(1000, 6_000, 2_000_000) == [(0, 320), (320, 640), (640, 960), (960, 1000)]
    for n, k in [(100, 50_000), (25, 300_000), (1000, 6_000), (7, 10)]:  # what the resource model holds is the largest batch
        assert trials_held(n, k) == max(hi - lo for lo, hi in trial_batches(n, k))
    from scintrack import simd
    from scintrack.trackers import blocks
    assert blocks.LANES is simd.LANES == 32


def test_row_sum_is_numpys_axis0_sum_bit_for_bit():
    rng = np.random.default_rng(0)
    a = rng.standard_normal((37, 501)) * np.exp(5 * rng.standard_normal((37, 501)))
    a[0, :3] = -0.0
    acc = RowSum()
    for lo, hi in [(0, 5), (5, 6), (6, 37)]:
        acc.add(a[lo:hi])
    assert acc.total.tobytes() == a.sum(axis=0).tobytes()


def test_s4_statistics_in_batches_equal_all_at_once():
    rng = np.random.default_rng(1)
    s4 = rng.uniform(0.1, 1.0, (9, 400))
    s4[2, :150] = np.nan  # not estimable at the start of one trial
    s4[5, :] = np.inf  # never estimable
    steady = slice(100, None)
    mean, med, frac = s4_statistics(s4, 10, steady)
    acc = S4Statistics()
    med_b = np.concatenate([acc.add(s4[:4], steady), acc.add(s4[4:], steady)])
    mean_b, frac_b = acc.result(10)
    assert mean.tobytes() == mean_b.tobytes() and med.tobytes() == med_b.tobytes() and frac.tobytes() == frac_b.tobytes()
    assert np.isnan(med[5]) and np.isfinite(med[2]) and frac[0] == pytest.approx(7 / 9)


@pytest.mark.parametrize(("n", "k"), [(500, 5), (50, 2), (100, 1), (8, 2), (65, 2), (200, 3), (1000, 7), (31, 4)])
def test_shards_are_contiguous_and_take_no_more_lane_blocks_than_needed(n, k):
    """Shards deal the trials out in whole lane blocks when that takes fewer blocks (500 in 5 shards: 16 blocks,
    not 5 x 4), else evenly (50 in 2: 25 + 25); every shard non-empty, together every trial once, in order."""
    from scintrack.pipeline.params import shard_trials
    from scintrack.simd import LANES

    cfg = {"experiments": {"x": {"trials": n, "shards": k}}}
    shards = [shard_trials(cfg, "x", i) for i in range(k)]
    assert [t for s in shards for t in s] == list(range(n)) and all(shards)
    blocks = sum(-(-len(s) // LANES) for s in shards)
    even = [round(i * n / k) for i in range(k + 1)]
    even_blocks = sum(-(-(hi - lo) // LANES) for lo, hi in zip(even, even[1:]))
    assert blocks == min(even_blocks, max(-(-n // LANES), k))
    if blocks == even_blocks:
        assert [len(s) for s in shards] == [hi - lo for lo, hi in zip(even, even[1:])]
    assert (n, k) != (500, 5) or blocks == 16
