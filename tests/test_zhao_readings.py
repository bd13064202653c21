"""Zhao et al.: the pre-declared readings of the position spread (``zhao_readings``).

Closed forms of the receiver options the readings add (code phase at the
integer sample, DLL without carrier aiding), the configuration of a reading
(overrides merged, bad settings refused in one line), the pre-declared
verdict, and the readings table on hand-made receiver results.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
import xarray as xr
from conftest import REPO

from scintrack.config import load_config
from scintrack.experiments import zhao_readings as zr
from scintrack.experiments.gps_channel_result import _code_phase_rate, sample_quantised
from scintrack.navigation import dll
from scintrack.pipeline import params, paths
from scintrack.signals.gps.orbit import C_LIGHT

FS = 12.5e6


@pytest.fixture(scope="module")
def config():
    return load_config([REPO / "config" / "config.yaml"])


# --- (b) code phase at the integer sample ----------------------------------------------


def test_sample_quantised_is_on_the_grid_within_half_a_step_and_idempotent():
    step = C_LIGHT / FS  # 23.98 m
    rng = np.random.default_rng(np.random.SeedSequence(20141))
    pr = 2.0e7 + rng.uniform(0.0, 1.0e4, 20000)
    q = sample_quantised(pr, FS)
    k = q / step
    np.testing.assert_allclose(k, np.round(k), atol=1e-6)  # whole samples of delay
    assert np.max(np.abs(q - pr)) <= step / 2 + 1e-6
    np.testing.assert_array_equal(sample_quantised(q, FS), q)
    # a code phase sweeping across the sample grid: uniform error, std step / sqrt(12) (6.9 m at 12.5 MS/s)
    assert np.std(q - pr) == pytest.approx(step / np.sqrt(12.0), rel=0.02)


def test_code_phase_setting_needs_the_sampling_rate():
    assert _code_phase_rate({"receiver": {}}) is None
    assert _code_phase_rate({"receiver": {"code_phase": "sample"}, "sample_rate_hz": FS}) == FS
    with pytest.raises(ValueError, match=r"^zhao_receiver\.code_phase: 'sample' needs"):
        _code_phase_rate({"receiver": {"code_phase": "sample"}})


# --- (c) DLL without carrier aiding ---------------------------------------------------


@pytest.mark.parametrize("n_int", [1, 20])
def test_unaided_loop_lags_a_held_doppler_error_by_the_ramp_closed_form(n_int):
    """A perfect carrier tracker (no phase or frequency error) and a code NCO holding a Doppler ``f`` off the
    truth: the code ramp ``r = f/1540`` is followed by the loop alone, with the first-order lag ``r T / g``."""
    bl, f_hold_err, n = 1.0, 25.0, 6000
    out = dll.run(np.zeros((1, n, 6)), 45.0, np.ones(n), 0.0, 0.0, spacing_chips=1.0, bandwidth_hz=bl, integration_ms=n_int,
                  aiding_error_hz=np.full(n, f_hold_err))[0]
    t = n_int * 1e-3
    np.testing.assert_allclose(out[-3 * n_int:], f_hold_err / 1540.0 * t / dll.loop_gain(bl, t), rtol=1e-9)
    # no aiding error: the code error stays at zero whatever the carrier tracker's frequency error
    still = dll.run(np.zeros((1, n, 6)), 45.0, np.ones(n), 0.0, 3.0, spacing_chips=1.0, bandwidth_hz=bl, integration_ms=n_int,
                    aiding_error_hz=0.0)[0]
    assert np.max(np.abs(still)) < 1e-12


def test_aiding_error_defaults_to_the_carrier_trackers_frequency_error():
    rng = np.random.default_rng(np.random.SeedSequence(20142))
    noise = rng.standard_normal((2, 400, 6))
    f_err = rng.normal(0.0, 2.0, 400)
    kw = dict(spacing_chips=1.0, bandwidth_hz=2.0, integration_ms=20, gain="fixed", cn0_ref_dbhz=46.0)
    a = dll.run(noise, 30.0, np.ones(400), 0.1, f_err, **kw)
    b = dll.run(noise, 30.0, np.ones(400), 0.1, f_err, aiding_error_hz=f_err, **kw)
    np.testing.assert_array_equal(a, b)


# --- the configuration of a reading ----------------------------------------------------


def test_reading_receiver_merges_overrides_key_by_key(config):
    rc = zr.reading_receiver(config, "Z-c_1Hz")
    assert rc["dll"]["carrier_aiding"] is False and rc["dll"]["bandwidth_hz"] == 1.0
    assert rc["dll"]["spacing_chips"] == config["zhao_receiver"]["dll"]["spacing_chips"]  # kept
    assert rc["trials"] == config["zhao_readings"]["trials"] and rc["variants"] == config["zhao_readings"]["variants"]
    assert zr.reading_receiver(config, "Z-a")["dll"] == config["zhao_receiver"]["dll"]
    assert zr.reading_receiver(config, "Z-d")["corrections"] is False
    assert zr.reading_receiver(config, "Z-e")["variants"] == ["mm_none"]  # clean scenario: PLL statistics, no priors


def test_reading_params_carry_the_sampling_rate_and_the_clean_dataset(config):
    p = params.zhao_reading(config, "Z-b")
    assert p["sample_rate_hz"] == config["gps_jamming"]["iq"]["sample_rate_hz"]
    assert "sample_rate_hz" not in params.zhao_reading(config, "Z-a")
    clean = params.zhao_reading(config, "Z-e")["dataset"]
    assert clean["jammer"]["onset_s"] == zr.CLEAN_ONSET_S > config["gps_jamming"]["duration_s"]
    assert {k: v for k, v in clean.items() if k != "jammer"} == {k: v for k, v in params.gps_dataset(config).items() if k != "jammer"}
    assert paths.gps_clean_dataset_path(config) != paths.gps_dataset_path(config)
    assert config["gps_jamming"]["jammer"]["onset_s"] != zr.CLEAN_ONSET_S  # the config itself is not changed


@pytest.mark.parametrize(("reading", "match"), [
    ({"receiver": {"dll": {"bandwith_hz": 1.0}}}, r"^zhao_readings\.readings\.bad\.receiver\.dll\.bandwith_hz: not a DLL setting"),
    ({"receiver": {"trials": 3}}, r"^zhao_readings\.readings\.bad\.receiver\.trials: not a receiver setting"),
    ({"scenario": "clean"}, r"^zhao_readings\.readings\.bad: a clean-scenario reading needs jammed_from"),
    ({"scenario": "clean", "jammed_from": "Z-e"}, r"^zhao_readings\.readings\.bad\.jammed_from: 'Z-e' must name a jammed-scenario"),
])
def test_bad_reading_is_refused_in_one_line(config, reading, match):
    cfg = copy.deepcopy(config)
    cfg["zhao_readings"]["readings"]["bad"] = reading
    with pytest.raises(ValueError, match=match):
        zr.reading_receiver(cfg, "bad")


# --- the pre-declared verdict and the table ----------------------------------------------


def test_verdict_follows_the_declared_criterion():
    clean, jammed = np.array(zr.PAPER_STD["clean"]), np.array(zr.PAPER_STD["jammed"])
    assert zr.verdict(clean, jammed) == "explains"  # the paper's own values (ratios 1.23-1.39)
    assert zr.verdict(clean * 1.49, jammed * 1.49) == "explains"
    assert zr.verdict(clean / 3, jammed / 3) == "explains part (ratios only)"
    assert zr.verdict(clean, clean * 0.95) == "explains part (standard deviations only)"  # ratio 0.95 < 1
    assert zr.verdict(clean / 3, clean / 6) == "does not explain"


def _receiver(name, clean_std, jammed_std, scenario="jammed", jammed_from="", trials=5):
    rng = np.random.default_rng(np.random.SeedSequence([20143, trials]))
    shape = (2, trials, 3)  # tracker, trial, axis

    def around(v):
        return np.asarray(v, float)[None, None, :] * (1.0 + 0.01 * rng.standard_normal(shape))

    ds = xr.Dataset({f"enu_{stat}_{seg}": (("tracker", "trial", "axis"), around(v if stat == "std" else [1.0, 1.0, 1.0]))
                     for seg, v in (("clean", clean_std), ("jammed", jammed_std)) for stat in ("mean", "std")},
                    coords={"tracker": ["pll", "mm_iode"], "trial": np.arange(trials), "axis": ["east", "north", "up"]})
    ds.attrs.update(reading=name, scenario=scenario, jammed_from=jammed_from)
    return ds


def test_readings_table_pairs_a_clean_scenario_with_its_jammed_reading():
    from scintrack.products.tables.zhao_jamming import zhao_table_readings

    a = _receiver("Z-a", [4.0, 5.0, 10.0], [5.0, 6.0, 12.0])
    e = _receiver("Z-e", [13.0, 23.0, 50.0], [np.nan] * 3, scenario="clean", jammed_from="Z-a")
    p = _receiver("Z-p", zr.PAPER_STD["clean"], zr.PAPER_STD["jammed"])
    out = zhao_table_readings(a, e, p)
    summary = out["table_readings_synthetic"][0].set_index("reading")
    assert summary.loc["Z-a", "verdict (pre-declared)"] == "explains part (ratios only)"
    assert summary.loc["Z-p", "verdict (pre-declared)"] == "explains"
    # Z-e: clean from its own (clean-scenario) run, jammed from Z-a: ratios 5/13, 6/23, 12/50 < 1
    assert summary.loc["Z-e", "verdict (pre-declared)"] == "does not explain"
    enu = out["table_readings_enu_synthetic"][0]
    ze = enu[(enu.reading == "Z-e") & (enu.statistic == "std")].set_index(["segment", "axis"])["reproduced"]
    assert ze[("jammed", "up")] == pytest.approx(12.0, rel=0.02) and ze[("clean", "up")] == pytest.approx(50.0, rel=0.02)
