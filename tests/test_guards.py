"""Numerical guards (scintrack.experiments.guards): first epoch and reason of divergence, the sanitised
estimate, the kernels' covariance flag, the runner's stored flags, the merge and the figure/table note."""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
import pytest
import xarray as xr
from conftest import REPO

from scintrack.config import load_config
from scintrack.experiments import guards
from scintrack.experiments.runner import merge, run_shard
from scintrack.models.ar import ScintillationAR
from scintrack.signals.correlator import complex_noise, noise_power, prompts
from scintrack.signals.dynamics import third_order_phase
from scintrack.trackers import blocks, registry
from scintrack.trackers.aekf_ar import AEKFAR
from scintrack.trackers.base import Tracker, TrackInit, TrackOutput
from scintrack.trackers.kf import DiscriminatorKF
from scintrack.trackers.mm_kf import MMKF, mm_kf_kernel
from scintrack.trackers.pll import PLL
from scintrack.trackers.susi_kf import SusiKF

TS = 0.01


@pytest.fixture(scope="module")
def config():
    return load_config([REPO / "config" / "config.yaml"])


def _ramp(n=3, k=60, doppler_hz=1200.0, ts=0.001):
    """Phases of a 1200-Hz carrier at 1 ms: 7.5 rad per epoch, a legitimate step the guard must not flag."""
    return np.tile(2 * np.pi * doppler_hz * ts * np.arange(k), (n, 1)) + np.arange(n)[:, None]


def test_known_first_epoch_and_reason_of_each_kind():
    th = _ramp(5)
    th[1, 17:] = np.nan  # non-finite from 17
    th[2, 30] += 10.0  # a 10-rad jump at 30: second difference 10 > 2 pi at epoch 30
    th[3, 40:] = 1e13  # beyond the phase limit: non-finite in effect (would overflow e^4)
    cov = np.array([-1, -1, -1, -1, 9])
    div = guards.detect(TrackOutput(th, {"cov_fail_epoch": cov}), 0.001)
    assert div.epoch.dtype == np.int64
    assert list(div.epoch) == [-1, 17, 30, 40, 9]
    assert list(div.reason) == [0, 1, 3, 1, 2]
    assert list(div.flagged) == [False, True, True, True, True]


def test_ties_go_to_the_covariance_and_allowed_extras_are_not_flagged():
    th = _ramp(3)
    th[0, 12:] = np.nan
    s4 = np.full(th.shape, 0.5)
    s4[:, :20] = np.nan  # "not estimable": documented, never a divergence
    freq = np.zeros(th.shape)
    freq[2, 25] = np.inf  # a non-finite extra that is not allowed
    div = guards.detect(TrackOutput(th, {"cov_fail_epoch": np.array([12, -1, -1]), "s4_hat": s4, "log_odds": np.full(th.shape, np.inf),
                                         "frequency_hz": freq}))
    assert list(div.epoch) == [12, -1, 25]
    assert list(div.reason) == [2, 0, 1]


def test_sanitize_holds_the_last_finite_value_and_leaves_other_trials_alone():
    th = _ramp(3, k=10)
    th[1, 4:] = np.nan
    th[2, :] = np.nan  # never finite: the fallback (acquisition phase)
    tot = th + 0.25
    tot[0] = np.nan  # ... in trial 0 only the total phase is bad (from 0)
    out = TrackOutput(th.copy(), {"total_phase": tot.copy(), "cov_fail_epoch": np.full(3, -1)})
    div = guards.detect(out)
    assert list(div.epoch) == [0, 4, 0] and list(div.reason) == [1, 1, 1]
    fixed = guards.sanitize(out, div, fallback=np.array([7.0, 8.0, 9.0]))
    assert np.all(np.isfinite(fixed.theta_d)) and np.all(np.isfinite(fixed.extras["total_phase"]))
    np.testing.assert_array_equal(fixed.theta_d[1, 4:], th[1, 3])  # held at epoch 3's value
    np.testing.assert_array_equal(fixed.theta_d[1, :4], th[1, :4])
    np.testing.assert_array_equal(fixed.theta_d[2], 9.0)
    np.testing.assert_array_equal(fixed.theta_d[0], th[0])  # finite theta_d of trial 0 untouched
    np.testing.assert_array_equal(fixed.extras["total_phase"][0], 7.0)
    assert np.array_equal(out.theta_d, th, equal_nan=True)  # the input is not modified
    clean = TrackOutput(_ramp(), {})
    assert guards.sanitize(clean, guards.detect(clean)) is clean  # nothing diverged: the very same arrays


def test_covariance_test_kernel_and_ufunc_agree_on_edge_values():
    cases = [(1.0, 1.0, 0.5, True), (0.0, 0.0, 0.0, True), (-0.0, 1.0, 0.0, True), (-1e-300, 1.0, 0.0, False), (np.nan, 1.0, 0.0, False),
             (1.0, np.inf, 0.0, False), (1.0, 1.0, np.nan, False), (1.0, 1.0, 1.0 + 1e-9, True), (1.0, 1.0, 1.01, False), (1.0, 4.0, -2.0, True)]
    a, b, c, want = (np.array(v) for v in zip(*cases))
    assert list(blocks.covariance_ok_ufunc(a, b, c)) == list(want)
    assert [bool(blocks.covariance_ok(x, y, z)) for x, y, z, _ in cases] == list(want)


def _signal(n=4, k=600, cn0=35.0, seed=3):
    thd = third_order_phase(np.zeros(n), k, TS, 50.0, 100.0)
    y = prompts(thd, 1.0, complex_noise(seed, "guards", range(n), k, noise_power(cn0, TS)))
    return y, TrackInit(phase=np.angle(y[:, 0]), doppler_hz=np.full(n, 50.0), rate_hz_s=np.zeros(n))


def _kernels(p0):
    sets = [ScintillationAR.from_coefs([0.99], [1.8, -0.9, 0.05], 0.05, 4e-4, 1e-4, s4=0.5)]
    return {
        "kf": DiscriminatorKF(ts=TS, q_jerk=0.01, nominal_cn0_hz=3000.0, p0_diag=p0),
        "akf_ar": DiscriminatorKF(ts=TS, q_jerk=0.01, nominal_cn0_hz=3000.0, p0_diag=p0, adaptive_r=True, ar_coefs=np.array([0.99]), ar_sigma2=4e-4),
        "aekf_ar": AEKFAR(ts=TS, q_jerk=0.01, p0_diag=p0, ar_sets=sets, nominal_noise=0.3),
        "susi": SusiKF(ts=TS, clock="ocxo", q_jerk=0.01, nominal_cn0_hz=3000.0, p0_diag=p0, discriminator="atan2"),
    }


def test_every_kalman_kernel_flags_a_covariance_that_is_not_positive_semi_definite():
    y, init = _signal()
    for name, tr in _kernels((0.25, 1.0, 1e4)).items():
        for out in (tr.run(y, init), tr.reference(y, init)):
            np.testing.assert_array_equal(out.extras["cov_fail_epoch"], -1, err_msg=name)
            assert not guards.detect(out, TS).any, name
    for name, tr in _kernels((0.25, -1.0, 1e4)).items():  # a negative frequency variance: not PSD from epoch 0
        for out in (tr.run(y, init), tr.reference(y, init)):
            np.testing.assert_array_equal(out.extras["cov_fail_epoch"], 0, err_msg=name)
            div = guards.detect(out, TS)
            assert np.all(div.epoch == 0) and np.all(div.reason == 2), name
    # MM KF: P0 is validated (>= 0), so hand the kernel a NaN phase variance directly
    mm = MMKF(ts=0.02)
    y20 = np.ascontiguousarray(y[:, :200])  # the layout MMKF.run hands the kernel (a strided view would compile a second overload)
    prm = mm.params(y20, init)
    np.testing.assert_array_equal(mm_kf_kernel(y20, prm)[-1], -1)
    P0 = prm.P0.copy()
    P0[1:, 1, 1] = np.nan
    np.testing.assert_array_equal(mm_kf_kernel(y20, prm._replace(P0=P0))[-1], [-1, 0, 0, 0])


def test_nan_prompts_and_an_absurd_q_are_flagged():
    y, init = _signal()
    y[2, 300:] = np.nan
    for tr in (PLL(ts=TS, bandwidth_hz=10.0), *_kernels((0.25, 1.0, 1e4)).values()):
        div = guards.detect(tr.run(y, init), TS)
        assert list(div.flagged) == [False, False, True, False], type(tr).__name__
        assert div.epoch[2] == 300 and div.reason[2] in (1, 2), type(tr).__name__
    with pytest.raises(ValueError, match="NaN or inf prompts"):  # the MM KF refuses them up front
        MMKF(ts=0.02).run(y, init)
    y, init = _signal()
    div = guards.detect(DiscriminatorKF(ts=TS, q_jerk=1e300, nominal_cn0_hz=3000.0, p0_diag=(0.25, 1.0, 1e4)).run(y, init), TS)
    assert np.all(div.flagged) and np.all(div.reason == 2) and np.all(div.epoch < 5)


@registry.register("toy_nan_after")
@dataclass
class NanAfter(Tracker):
    """A PLL whose output turns NaN from ``epoch`` on in the odd rows of its batch (a constructed divergence)."""

    ts: float
    epoch: int

    SCHEMA = {"epoch": {"type": "integer"}}
    TRACKING_KEYS = ()
    PROVIDES = PLL.PROVIDES

    @classmethod
    def from_spec(cls, spec, context):
        return cls(ts=context.ts, epoch=int(spec["epoch"]))

    @staticmethod
    def label(name, spec):
        return "NaN-PLL"

    def run(self, y, init):
        out = PLL(ts=self.ts, bandwidth_hz=10.0).run(y, init)
        for key in ("discriminator", "frequency_hz"):
            out.extras[key][1::2, self.epoch :] = np.nan
        out.theta_d[1::2, self.epoch :] = np.nan
        return out


STRICT = ("sq_sum", "sq2_sum", "ms_steady", "slips", "slip_events", "ms_total_steady", "slips_total", "slip_events_total", "time_in_lock",
          "example_error", "rmse", "rmse_lo", "rmse_hi", "steady_rmse", "steady_rmse_total", "jitter_discriminator", "jitter_tracking")


def test_runner_stores_flags_counts_the_lost_lock_and_merges_them(config):
    specs = dict(config["trackers"], nan_pll={"type": "toy_nan_after", "epoch": 150})
    sc = dict(config["scenarios"]["free"], duration_s=3.0)
    tracking = dict(config["tracking"], steady_state_start_s=1.0, jitter_window_s=1.0)
    kw = dict(scenario_name="free", scenario=sc, tracker_names=["pll", "nan_pll"], tracker_specs=specs, tracking=tracking, lut=None, seed=2, ts=TS,
              nspa=8, warmup_s=0.0)
    shards = [run_shard(**kw, trials=range(0, 2)), run_shard(**kw, trials=range(2, 4))]  # odd rows of each shard = odd trials
    res = merge(shards[::-1])
    assert res["diverged_epoch"].dtype == np.int64
    np.testing.assert_array_equal(res["diverged_epoch"].sel(tracker="pll").values, -1)
    np.testing.assert_array_equal(res["diverged_epoch"].sel(tracker="nan_pll").values, [-1, 150, -1, 150])
    np.testing.assert_array_equal(res["divergence_reason"].sel(tracker="nan_pll").values, [0, 1, 0, 1])
    assert "non_finite_estimate" in res["divergence_reason"].attrs["flag_meanings"]
    assert res["diverged_epoch"].attrs["epoch_period_s"] == TS
    for key in STRICT:
        assert np.all(np.isfinite(res[key].values)), key
    # the frozen NCO of a lost loop under a 100 Hz/s ramp: large error, slips, out of lock -- counted, not dropped
    ms = res["ms_steady"].sel(tracker="nan_pll", kind="wrapped").values
    assert np.all(ms[1::2] > 1.0) and np.all(ms[::2] < 0.5)
    assert np.all(res["slips"].sel(tracker="nan_pll").values[1::2] > 10)
    assert np.all(res["time_in_lock"].sel(tracker="nan_pll").values[1::2] < 0.5)
    # the unaffected trials are the PLL's, bit for bit (the guard changes nothing else)
    np.testing.assert_array_equal(res["ms_steady"].sel(tracker="nan_pll").values[:, ::2], res["ms_steady"].sel(tracker="pll").values[:, ::2])
    note = guards.divergence_note([res, xr.Dataset()])
    assert note.startswith("Diverged (numerical guard): NaN-PLL 2/4 trials on free (first at 1.5 s)")
    assert "PLL 0/" not in note


def test_note_is_empty_without_flags_and_counts_non_estimable_s4():
    ds = xr.Dataset(
        {"diverged_epoch": (("tracker", "trial"), np.full((2, 4), -1, dtype=np.int64), {"epoch_period_s": 0.01}),
         "s4_hat_estimable": (("tracker", "time"), np.array([[np.nan, np.nan], [1.0, 1.0]]))},
        coords={"tracker": ["kf", "aekf_ar"]}, attrs={"tracker_labels": json.dumps({"kf": "KF", "aekf_ar": "AEKF-AR"}), "scenario": "s"},
    )
    assert guards.divergence_note(ds) == ""
    ds["s4_hat_estimable"][1, 0] = 0.5
    ds["diverged_epoch"][0, 2] = 1230
    note = guards.divergence_note(ds)
    assert "KF 1/4 trials on s (first at 12.3 s)" in note
    assert "On-line S4 not estimable" in note and "AEKF-AR on s 25%" in note


def test_figures_get_the_note_as_a_footer_and_tables_as_a_note_line(tmp_path):
    from scintrack.products.figures.common import add_footer, new_figure, save_figure
    from scintrack.products.tables.common import join_notes, write_table

    fig, _ = new_figure(1, 1)
    add_footer(fig, "")
    assert fig.texts == []
    note = "Diverged (numerical guard): KF 1/4 trials on s (first at 12.3 s)."
    ax = fig.axes[0]
    ax.set_xlabel("time [s]")
    fig.tight_layout()
    add_footer(fig, note * 4)  # long enough to wrap
    assert len(fig.texts) == 1 and fig.texts[0].get_text().replace("\n", " ") == (note * 4).replace("\n", " ").strip()
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    footer = fig.texts[0].get_window_extent(renderer)
    assert footer.y1 <= ax.get_tightbbox(renderer).y0 + 1  # below the axis label, not over it
    assert footer.x1 <= fig.bbox.x1 + 1  # wrapped to the figure's width
    save_figure(fig, [tmp_path / "f.png"])
    assert join_notes("Own note.", "") == "Own note." and join_notes("Own note.", note) == f"Own note. {note}" and join_notes("", note) == note
    import pandas as pd

    write_table(pd.DataFrame({"a": [1.0]}), tmp_path / "t.csv", tmp_path / "t.md", title="T", note=join_notes("Own note.", note))
    assert note in (tmp_path / "t.md").read_text()
    for script in ("render_figure.py", "render_table.py"):  # every registered figure and table goes through these two
        assert "divergence_note(" in (REPO / "workflow" / "scripts" / script).read_text()


def test_s4_statistics_are_the_plain_ones_without_nan_and_nan_aware_with_it():
    from scintrack.experiments.runner import block_mean, s4_statistics

    s4 = np.random.default_rng(1).uniform(0.2, 0.9, (5, 40))
    steady = slice(10, None)
    mean, med, frac = s4_statistics(s4, 4, steady)
    assert np.array_equal(mean, block_mean(s4.mean(axis=0), 4)) and np.array_equal(med, np.median(s4[:, steady], axis=1))
    np.testing.assert_array_equal(frac, 1.0)
    s4[0, :] = np.nan  # a trial never estimable
    s4[:, :4] = np.nan  # a block where nothing is
    s4[1, 20:22] = np.nan
    with np.errstate(all="raise"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("error")
            mean, med, frac = s4_statistics(s4, 4, steady)
    assert np.isnan(mean[0]) and np.all(np.isfinite(mean[1:]))
    np.testing.assert_allclose(mean[5], np.nanmean(s4[:, 20:24]), rtol=1e-15)
    assert np.isnan(med[0]) and np.all(np.isfinite(med[1:]))
    np.testing.assert_allclose(frac[[0, 1, 5]], [0.0, 0.8, (20 - 4 - 2) / 20])  # block 5: trial 0 (4 epochs) and 2 epochs of trial 1 missing
