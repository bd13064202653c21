"""Config values that pass the schema's types but would not give sound results.

* ``trials: 1``: a 95% interval needs the spread over two or more trials; from
  one trial every interval has NaN bounds (never a zero-width ``[x, x]``), the
  estimate itself is kept, tables and the comparison page say "no interval"
  in words, and a verdict that needs an interval is not claimed.
* ``seed``: bounded by the schema to what every dataset writer stores
  (an unsigned 64-bit NetCDF attribute); the largest allowed seed runs through
  the writer, one more is refused in one ``error:`` line naming the key and
  the config layer.
* a key given twice in one YAML mapping (config or ``--configfile`` overlay,
  top level or nested) is refused in one ``error:`` line with file:line and key.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr
import yaml
from conftest import REPO, run_snakemake

from scintrack.config import load_config, validate_config
from scintrack.errors import ConfigError
from scintrack.experiments.metrics import Z95, mean_ci, mean_with_ci, rmse_with_ci, steady_rmse
from scintrack.products.tables.common import NO_INTERVAL, estimate_text, interval_text
from scintrack.yamlio import DuplicateKeyError, yaml_load

SCHEMA = REPO / "workflow" / "schemas" / "config.schema.yaml"


def _one_error_line(proc: subprocess.CompletedProcess) -> str:
    """The single ``error:`` line of a refused run (non-zero exit, no traceback)."""
    out = proc.stdout + proc.stderr
    assert proc.returncode != 0, out[-2000:]
    lines = [line for line in out.splitlines() if line.startswith("error: ")]
    assert len(lines) == 1, out[-2000:]
    assert "Traceback" not in out, out[-2000:]
    return lines[0]


# --- trials: 1 ---------------------------------------------------------------------------------------


def test_interval_functions_give_nan_bounds_from_one_trial_and_the_normal_interval_from_more():
    sq, sq2 = np.array([0.25, 1.0]), np.array([0.0625, 1.0])
    rmse, lo, hi = rmse_with_ci(sq, sq2, 1)
    np.testing.assert_allclose(rmse, [0.5, 1.0])  # the estimate is kept
    assert np.isnan(lo).all() and np.isnan(hi).all()
    e2 = np.array([[0.1, 0.4, 0.2, 0.9], [1.0, 1.2, 0.8, 1.1]])  # (epoch, trial) squared errors
    rmse, lo, hi = rmse_with_ci(e2.sum(1), (e2**2).sum(1), 4)
    half = Z95 * e2.std(axis=1, ddof=1) / 2
    np.testing.assert_allclose(rmse, np.sqrt(e2.mean(1)))
    np.testing.assert_allclose(lo, np.sqrt(np.maximum(e2.mean(1) - half, 0)))
    np.testing.assert_allclose(hi, np.sqrt(e2.mean(1) + half))

    s, lo, hi = steady_rmse(np.array([[1.2522]]), axis=-1)
    assert s == pytest.approx([math.sqrt(1.2522)]) and np.isnan(lo).all() and np.isnan(hi).all()
    ms = np.array([0.5, 0.7, 0.6])
    s, lo, hi = steady_rmse(ms)
    half = Z95 * ms.std(ddof=1) / math.sqrt(3)
    assert (s, lo, hi) == pytest.approx((math.sqrt(ms.mean()), math.sqrt(ms.mean() - half), math.sqrt(ms.mean() + half)))

    m, lo, hi = mean_with_ci(np.array([3.0]))
    assert m == 3.0 and math.isnan(lo) and math.isnan(hi)
    v = np.array([0.0, 1.0, 0.0, 5.0])
    half = Z95 * v.std(ddof=1) / 2
    assert mean_with_ci(v) == pytest.approx((1.5, 0.0, 1.5 + half))  # clipped at 0
    assert mean_with_ci(v, lower=None) == pytest.approx((1.5, 1.5 - half, 1.5 + half))

    x = np.array([[1.0, 2.0], [np.nan, 4.0], [np.nan, 3.0]])  # column 0: one finite value
    m, lo, hi = mean_ci(x, axis=0)
    half = 1.96 * np.std([2.0, 4.0, 3.0], ddof=1) / math.sqrt(3)
    assert m == pytest.approx([1.0, 3.0]) and math.isnan(lo[0]) and math.isnan(hi[0])
    assert (lo[1], hi[1]) == pytest.approx((3.0 - half, 3.0 + half))
    m, lo, hi = mean_ci(np.array([[2.0, 7.0]]), axis=0)  # one trial
    assert m == pytest.approx([2.0, 7.0]) and np.isnan(lo).all() and np.isnan(hi).all()


def test_interval_text_says_so_in_words():
    assert interval_text(1.119, 1.2, ".4f") == "[1.1190, 1.2000]"
    assert interval_text(float("nan"), float("nan"), ".4f") == NO_INTERVAL
    assert estimate_text(1.119, 1.0, 1.2) == "1.12 [1, 1.2]"
    assert estimate_text(1.119, float("nan"), float("nan")) == f"1.12 ({NO_INTERVAL})"
    assert estimate_text(float("nan"), float("nan"), float("nan")) == "nan [nan, nan]"


def _merged(trials: int) -> xr.Dataset:
    """A merged experiment result of ``trials`` trials (PLL and KF on the free-running scenario, 1.5 s)."""
    from scintrack.experiments.runner import merge, run_shard

    config = load_config([REPO / "config" / "config.yaml"])
    sc = dict(config["scenarios"]["free"], duration_s=1.5)
    tracking = dict(config["tracking"], steady_state_start_s=1.0)
    res = merge([run_shard(scenario_name="free", scenario=sc, tracker_names=["pll", "kf"], tracker_specs=config["trackers"],
                           tracking=tracking, lut=None, seed=1, ts=0.01, nspa=8, warmup_s=0.0, trials=range(trials))])
    res.attrs.update(experiment="case1_free", ts=0.01, cn0_dbhz=float(tracking["cn0_dbhz"]), fd0_hz=50.0, fr_hz_s=100.0)
    return res


@pytest.fixture(scope="module")
def one_trial() -> xr.Dataset:
    return _merged(1)


def test_a_one_trial_result_keeps_its_estimates_and_has_no_interval(one_trial):
    res = one_trial
    assert int(res["n_trials"]) == 1
    for v in ("steady_rmse", "steady_rmse_total", "rmse"):
        assert np.isfinite(res[v].values).all(), v
        assert np.isnan(res[f"{v}_lo"].values).all() and np.isnan(res[f"{v}_hi"].values).all(), v


def test_tables_of_a_one_trial_result_print_no_zero_width_interval(one_trial, tmp_path):
    from scintrack.archive.compare import collect, render, summary
    from scintrack.products.tables import vila_valls_2018 as vv
    from scintrack.products.tables import vila_valls_2018_aekf as aekf
    from scintrack.products.tables.twin import twin_rows

    res = one_trial
    s = float(res["steady_rmse"].sel(tracker="pll", kind="wrapped"))
    text = aekf.lock_rows([res]).set_index("tracker")["theta_d RMSE wrapped [rad]"]
    assert text["PLL"] == f"{s:.3g} ({NO_INTERVAL})"
    (grid, _, note), = vv._steady_grid([res], "t", "k", "").values()
    assert grid["rmse_wrapped"].tolist() == pytest.approx(res["steady_rmse"].sel(kind="wrapped").values.tolist())
    assert grid[["ci95_lo", "ci95_hi"]].isna().all(axis=None)
    assert "1 trial per cell, so no 95% intervals" in note

    # the comparison page: the interval column in words, never "within 95% CI", and the summary counts such cells
    cells = [{"row": "free", "column": "PLL", "paper": s * 1.1, "ours": s, "lo": float(res["steady_rmse_lo"].sel(tracker="pll", kind="wrapped")),
              "hi": float(res["steady_rmse_hi"].sel(tracker="pll", kind="wrapped"))},
             {"row": "free", "column": "KF", "paper": s, "ours": s, "lo": s, "hi": s}]
    twin = twin_rows(cells)
    assert twin["paper_within_ci95"].tolist() == [False, True]
    csv = tmp_path / "vila_valls_2018" / "tableX_vs_paper.csv"
    csv.parent.mkdir()
    twin.to_csv(csv, index=False)
    df = collect([csv])
    assert df["verdict"].tolist() == ["within 25%", "within 95% CI"]
    md, page = render(df)
    row = next(line for line in md.splitlines() if line.startswith("| free") and "PLL" in line)
    assert NO_INTERVAL in row and "[" not in row
    assert NO_INTERVAL in page
    assert summary(df).endswith(f"1 of them with {NO_INTERVAL}: their verdict rests on the 25% ratio alone.")
    assert "rests on" not in summary(df.iloc[1:])  # every cell with an interval: the line as it always was


def test_verdicts_that_need_an_interval_are_not_claimed_from_one_trial(one_trial):
    from scintrack.products.tables import ranking, susi_2014

    # ranking: whether an interval reaches the best one's is unknown without intervals (empty), not False
    long = ranking.ranking_long([one_trial])
    assert long["ci_overlaps_best"].isna().all()
    assert f"empty where there is {NO_INTERVAL}" in ranking.ranking_note(long, [one_trial])
    two = _merged(3)
    long3 = ranking.ranking_long([two])
    assert long3["ci_overlaps_best"].dtype == bool and long3["ci_overlaps_best"].tolist() == [True, False]
    assert "empty where" not in ranking.ranking_note(long3, [two])
    # Susi claims: a paired difference without an interval gives no verdict either way
    assert susi_2014.verdict([(-0.2, -0.3, -0.1), (-0.1, -0.2, -0.05)]) == "holds"
    assert susi_2014.verdict([(-0.2, float("nan"), float("nan")), (-0.1, -0.2, -0.05)]) == f"not evaluated: {NO_INTERVAL}"
    assert susi_2014.verdict([(float("nan"),) * 3]) == "not evaluated"
    assert susi_2014.fmt_ci(*susi_2014.paired(np.array([0.3]), np.array([0.5]))) == f"-0.2 ({NO_INTERVAL})"


# --- seed ---------------------------------------------------------------------------------------------


def _largest_seed() -> int:
    return int(yaml_load(SCHEMA.read_text())["properties"]["seed"]["maximum"])


def _schema_error(config: dict):
    """The first schema violation of ``config`` (None when it passes), as Snakemake's ``validate`` finds it."""
    import jsonschema

    validator = jsonschema.Draft202012Validator(yaml_load(SCHEMA.read_text()))
    return jsonschema.exceptions.best_match(validator.iter_errors(config))


def test_the_largest_allowed_seed_runs_through_the_dataset_writer(tmp_path):
    """Every data job splits its streams from the seed and stores it as a NetCDF attribute (:func:`scintrack.io.provenance`,
    :func:`scintrack.io.write_netcdf`, where a larger seed failed); the largest seed the schema allows passes both and reads back."""
    from scintrack.io import provenance, write_netcdf
    from scintrack.seeding import rng_for

    seed = _largest_seed()
    assert seed == 2**64 - 1
    assert _schema_error(dict(load_config([REPO / "config" / "config.yaml"]), seed=seed)) is None
    ds = xr.Dataset({"x": ("trial", rng_for(seed, "csm_train/test", 0).standard_normal(4))})
    ds.attrs.update(provenance(config={"seed": seed}, seed=seed))
    write_netcdf(ds, tmp_path / "x.nc")
    with xr.open_dataset(tmp_path / "x.nc") as back:
        assert int(back.attrs["seed"]) == seed
    ds.attrs["seed"] = seed + 1  # what the bound keeps out: the writer cannot store it, and leaves nothing behind
    with pytest.raises(TypeError):
        write_netcdf(ds, tmp_path / "y.nc")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.nc"]


def test_a_seed_beyond_the_largest_is_refused_in_one_line_naming_the_layer(tmp_path):
    """One more than the largest: the schema's one line, naming the key and the layer that sets it, as
    workflow/rules/common.smk reports it (:func:`scintrack.config.locate`)."""
    from scintrack.config import SOURCE, format_validation_error, locate

    config = load_config([REPO / "config" / "config.yaml"])
    overlay = tmp_path / "big_seed.yaml"
    overlay.write_text(f"seed: {_largest_seed() + 1}\n")
    merged = load_config([REPO / "config" / "config.yaml", overlay])
    error = _schema_error(merged)
    line = locate(format_validation_error(error, SOURCE), [("config/config.yaml", config), (str(overlay), load_config([overlay]))])
    assert line.startswith("invalid config value at 'seed': ") and "maximum" in line and line.endswith(f"fix it in {overlay}")
    assert "\n" not in line
    with pytest.raises(ConfigError, match="'seed'.*maximum.*mine.yaml"):
        validate_config(merged, SCHEMA, source="mine.yaml")


# --- duplicated keys -----------------------------------------------------------------------------------


def test_the_reader_refuses_a_repeated_key_at_any_depth():
    with pytest.raises(DuplicateKeyError) as err:
        yaml_load("seed: 1\nexperiments:\n  a: 1\nseed: 2\n")
    assert (err.value.key, err.value.first_line, err.value.line) == ("seed", 1, 4)
    with pytest.raises(DuplicateKeyError) as err:
        yaml_load("tracking:\n  cn0_dbhz: 40\n  other: 1\n  cn0_dbhz: 41\n")
    assert (err.value.key, err.value.first_line, err.value.line) == ("cn0_dbhz", 2, 4)
    with pytest.raises(DuplicateKeyError):  # in a list item, and by value: YAML 1.1 reads both as True
        yaml_load("a:\n  - {x: 1, y: 2}\n  - {yes: 1, true: 2}\n")
    with pytest.raises(yaml.YAMLError):  # a YAMLError to every reader of the project's YAML
        yaml_load("{a: 1, a: 1}")
    # a merge key is no repeat: the mapping's own keys override the merged ones, as with the safe loader
    text = "base: &b {x: 1, y: 2}\nuse:\n  <<: *b\n  y: 3\n"
    assert yaml_load(text) == yaml.safe_load(text) == {"base": {"x": 1, "y": 2}, "use": {"x": 1, "y": 3}}


def _shipped_with_a_repeat(nested: bool) -> tuple[str, str, int]:
    """config/config.yaml with one key repeated: (text, key, line of the repeat)."""
    lines = (REPO / "config" / "config.yaml").read_text().splitlines()
    if not nested:
        return "\n".join([*lines, "experiments: {}"]) + "\n", "experiments", len(lines) + 1
    i = lines.index("tracking:") + 1  # the block's first key, given again on the next line
    return "\n".join([*lines[: i + 1], lines[i], *lines[i + 1:]]) + "\n", lines[i].split(":")[0].strip(), i + 2


@pytest.mark.parametrize("nested", [False, True], ids=["top_level", "nested"])
def test_the_config_with_a_repeated_key_is_refused_with_file_and_line(tmp_path, nested):
    text, key, line = _shipped_with_a_repeat(nested)
    main = tmp_path / "config.yaml"
    main.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_config([main])
    message = str(err.value)
    assert message.startswith(f"config file {main}:{line}: key '{key}' is given twice") and "\n" not in message
    main.write_text(text.replace(f"{key}:", f"{key}_renamed:", 1))  # the same file without the repeat reads
    load_config([main])


@pytest.mark.pipeline
@pytest.mark.parametrize(
    "text, key, line",
    [
        ("experiments:\n  mine: {trials: 3}\nseed: 5\nexperiments:\n  other: {trials: 4}\n", "experiments", 4),
        ("tracking:\n  cn0_dbhz: 40\n  pll_bandwidth_hz: 10\n  cn0_dbhz: 30\n", "cn0_dbhz", 4),
    ],
    ids=["top_level", "nested"],
)
def test_an_overlay_with_a_repeated_key_is_refused_with_file_and_line(tmp_path, text, key, line):
    overlay = tmp_path / "overlay.yaml"
    overlay.write_text(text)
    with pytest.raises(ConfigError, match=rf"{overlay}:{line}: key '{key}' is given twice"):
        load_config([REPO / "config" / "config.yaml", overlay])
    # as a user meets it: repro.py's check of every --configfile, and Snakemake given the overlay directly
    check = subprocess.run([sys.executable, "-m", "scintrack", "check-config", str(overlay)], capture_output=True, text=True, cwd=REPO)
    assert f"{overlay}:{line}: key '{key}'" in _one_error_line(check)
    work = tmp_path / "work"
    (work / "results").mkdir(parents=True)
    (work / "results" / "kept.nc").write_bytes(b"computed")
    smk = _one_error_line(run_snakemake(work, "-n", "--configfile", str(overlay)))
    assert f"{overlay}:{line}: key '{key}'" in smk
    assert (work / "results" / "kept.nc").read_bytes() == b"computed"
