"""Configuration validation: schema bounds and one-line errors naming the key."""

from __future__ import annotations

import copy

import pytest
import yaml
from conftest import REPO, run_snakemake

from scintrack.config import load_config, validate_config
from scintrack.errors import ConfigError

SCHEMA = REPO / "workflow" / "schemas" / "config.schema.yaml"


@pytest.fixture()
def config():
    return load_config([REPO / "config" / "config.yaml"])


def test_shipped_configs_are_valid(config):
    validate_config(config, SCHEMA)
    validate_config(load_config([REPO / "config" / "config.yaml", REPO / "config" / "smoke.yaml"]), SCHEMA)


@pytest.mark.parametrize(
    "path, value, key",
    [
        (("ar_training", "s4", 0), -1, "ar_training.s4[0]"),
        (("ar_training", "s4", 1), 1.6, "ar_training.s4[1]"),
        (("ar_training", "tau0", 0), 0.0, "ar_training.tau0[0]"),
        (("sampling", "ts"), -0.01, "sampling.ts"),
        (("seed",), "abc", "seed"),
    ],
)
def test_bad_value_names_the_key(config, path, value, key):
    bad = copy.deepcopy(config)
    target = bad
    for p in path[:-1]:
        target = target[p]
    target[path[-1]] = value
    with pytest.raises(ConfigError) as err:
        validate_config(bad, SCHEMA)
    message = str(err.value)
    assert f"'{key}'" in message and "\n" not in message


def test_figure_case_off_grid_is_rejected(config):
    bad = copy.deepcopy(config)
    bad["figures"]["vila_valls_2018"]["ar_cases"]["severe"]["s4"] = 0.95
    with pytest.raises(ConfigError, match="ar_cases.severe"):
        validate_config(bad, SCHEMA)


def test_unknown_key_is_rejected(config):
    bad = copy.deepcopy(config)
    bad["ar_training"]["trails"] = 3
    with pytest.raises(ConfigError, match="trails"):
        validate_config(bad, SCHEMA)


def test_missing_file_and_bad_yaml(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        load_config([tmp_path / "nope.yaml"])
    broken = tmp_path / "broken.yaml"
    broken.write_text("a: 1\nb: [1, 2\n")
    with pytest.raises(ConfigError, match=r"broken.yaml:3:1 is not valid YAML"):
        load_config([broken])


def test_check_config_cli_names_file_and_line_and_misplaced_targets(tmp_path, capsys):
    from scintrack.__main__ import main

    broken = tmp_path / "broken.yaml"
    broken.write_text("seed: 1\ntracking:\n  cn0_dbhz: [1,\n")
    assert main(["check-config", str(broken)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "broken.yaml:4:1" in err
    assert main(["check-config", str(REPO / "config" / "smoke.yaml"), "fig01"]) == 2
    assert "put it before --configfile" in capsys.readouterr().err
    assert main(["check-config", str(REPO / "config" / "smoke.yaml")]) == 0


def test_command_line_overrides_get_yaml_types():
    from scintrack.config import typed_overrides

    # what Snakemake's --config parser hands over for tracking={"pll_bandwidth_hz": 15.0, ...}
    raw = {"tracking": {"pll_bandwidth_hz": "15.0", "p0_diag": ["0.25", "1", "1e4"], "note": "scenario"}, "seed": 3}
    typed = typed_overrides(raw)
    assert typed == {"tracking": {"pll_bandwidth_hz": 15.0, "p0_diag": [0.25, 1, "1e4"], "note": "scenario"}, "seed": 3}
    assert typed_overrides({"real_traces": "{sources: {}}"}) == {"real_traces": {"sources": {}}}


@pytest.mark.pipeline
def test_snakemake_stops_on_bad_value_with_one_line(tmp_path):
    overlay = tmp_path / "bad.yaml"
    overlay.write_text(yaml.safe_dump({"ar_training": {"s4": [-1, 0.5]}}))
    proc = run_snakemake(tmp_path, "-n", "--configfile", str(overlay))
    assert proc.returncode != 0
    out = proc.stdout + proc.stderr
    lines = [line for line in out.splitlines() if "invalid config value at 'ar_training.s4[0]'" in line]
    assert len(lines) == 1, out[-2000:]
    assert not (tmp_path / "data").exists()


@pytest.mark.parametrize(
    "edit, key",
    [
        (lambda c: c["scenarios"]["susi_high_latitude"]["trace"].update(name="nowhere"), "scenarios.susi_high_latitude.trace.name"),
        (lambda c: c["scenarios"]["susi_equatorial"].update(ts=0.002), "scenarios.susi_equatorial.ts"),
        (lambda c: c["scenarios"]["susi_equatorial"].update(duration_s=400.0), "susi_2014.traces.equatorial.duration_s"),
        (lambda c: c["floors"].update(scenarios=["severe_to_moderate"]), "floors.scenarios"),
    ],
)
def test_trace_scenarios_and_floors_are_checked(config, edit, key):
    import copy

    from scintrack.config import check_consistency
    from scintrack.errors import ConfigError

    cfg = copy.deepcopy(config)
    edit(cfg)
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")) as info:
        check_consistency(cfg)
    assert "\n" not in str(info.value)


def test_yaml_reader_gives_what_the_safe_loader_gives():
    """scintrack.yamlio reads every YAML file of the project to the same values as ``yaml.safe_load`` (libyaml's
    parser, same constructor and resolver), and refuses what the safe loader refuses."""
    import yaml

    from scintrack.yamlio import yaml_load

    files = [*sorted((REPO / "config").glob("*.yaml")), *sorted((REPO / "workflow" / "schemas").glob("*.yaml")),
             *sorted((REPO / "profiles").rglob("*.yaml")), *sorted((REPO / "data").glob("*.yaml"))]
    assert len(files) >= 4
    for path in files:
        text = path.read_text(encoding="utf-8")
        assert yaml_load(text) == yaml.safe_load(text), path
    for text in ("on: yes\nn: ~\nt: 2026-12-02\nf: 1e3\ni: 0x1f\n", "a: !!python/object/apply:os.system ['true']\n"):
        try:
            expected = yaml.safe_load(text)
        except yaml.YAMLError:
            with pytest.raises(yaml.YAMLError):
                yaml_load(text)
        else:
            assert yaml_load(text) == expected


def test_experiment_names_are_rule_names(config):
    """An experiment is the rule ``tracking_<name>``: a name that is not an identifier is refused in one line naming it."""
    bad = copy.deepcopy(config)
    bad["experiments"]["a.b"] = bad["experiments"]["case1_free"]
    with pytest.raises(ConfigError, match=r"experiments.*a\.b"):
        validate_config(bad, SCHEMA)

