"""The typed tracking settings: one field per key of the schema's ``tracking:`` section, no
default of their own (the schema's defaults reach them through the validated config), and a
one-line error naming a bad key."""

from __future__ import annotations

import copy
import dataclasses

import pytest
from conftest import REPO

from scintrack.config import load_config
from scintrack.errors import ConfigError
from scintrack.experiments.scenario import effective_tracking
from scintrack.pipeline import params as P
from scintrack.settings import EXPERIMENT_KEYS, FLOORS_KEYS, TrackingSettings
from scintrack.yamlio import yaml_load

SCHEMA = REPO / "workflow" / "schemas" / "config.schema.yaml"
JSON_TYPES = {"number": "float | None", "integer": "int | None"}


@pytest.fixture(scope="module")
def config():
    return load_config([REPO / "config" / "config.yaml"])


@pytest.fixture(scope="module")
def tracking_schema():
    schema = yaml_load(SCHEMA.read_text())
    section = schema["properties"]["tracking"]
    refs = {f"#/$defs/{k}": v for k, v in schema["$defs"].items()}
    return {**section, "properties": {k: refs.get(v.get("$ref"), v) for k, v in section["properties"].items()}}


def test_one_field_per_schema_key_with_its_type_and_no_default(tracking_schema):
    fields = {f.name: f for f in dataclasses.fields(TrackingSettings)}
    assert set(fields) == set(tracking_schema["properties"])
    for name, prop in tracking_schema["properties"].items():
        if prop.get("type") in JSON_TYPES:
            assert fields[name].type == JSON_TYPES[prop["type"]], name
        else:
            assert fields[name].type.startswith("tuple["), name
        assert fields[name].default is dataclasses.MISSING and fields[name].default_factory is dataclasses.MISSING, name
    assert set(EXPERIMENT_KEYS) <= set(fields) and set(FLOORS_KEYS) <= set(fields)


def test_the_defaults_are_the_schema_s(config, tracking_schema):
    """A config without the optional keys gets the schema's values through Snakemake's validate (set_default)."""
    from snakemake.utils import validate

    defaults = {k: v["default"] for k, v in tracking_schema["properties"].items() if "default" in v}
    assert set(defaults) == set(tracking_schema["properties"]) - set(tracking_schema["required"])  # every optional key has one
    cfg = copy.deepcopy(config)
    for key in defaults:
        cfg["tracking"].pop(key, None)
    validate(cfg, str(SCHEMA))
    settings = TrackingSettings.from_params(P.experiment(cfg, "case2_steady_state", "s4_0.8_tau0_0.2")["tracking"], require=EXPERIMENT_KEYS)
    assert {k: getattr(settings, k) for k in defaults} == defaults


def test_every_experiment_s_params_give_its_settings(config):
    for name, exp in config["experiments"].items():
        for scenario in exp["scenarios"]:
            run = P.experiment(config, name, scenario)
            settings = effective_tracking(run["scenario"], run["tracking"])
            assert settings.given().keys() == {**run["tracking"], **run["scenario"].get("tracking", {})}.keys()
            assert settings.lock_threshold == float(config["tracking"]["lock_threshold"])
    floors = P.floors(config, config["floors"]["scenarios"][0])["tracking"]
    assert TrackingSettings.from_params(floors, require=FLOORS_KEYS).given().keys() == set(FLOORS_KEYS)


def test_values_are_typed_and_not_given_keys_are_none():
    s = TrackingSettings.from_params({"cn0_dbhz": 30, "cn0_window": 50.0, "p0_diag": [1, 2, 3], "adaptation_points": [[0.5, 0.4]]})
    assert s.cn0_dbhz == 30.0 and type(s.cn0_dbhz) is float and s.cn0_window == 50 and type(s.cn0_window) is int
    assert s.p0_diag == (1.0, 2.0, 3.0) and s.adaptation_points == ((0.5, 0.4),)
    assert s.lock_threshold is None and "lock_threshold" not in s.given()
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.cn0_dbhz = 1.0


def test_a_bad_key_gives_one_line_naming_it(config):
    with pytest.raises(ConfigError, match=r"^tracking\.lock_treshold: not a tracking setting \(known: .*lock_threshold") as err:
        TrackingSettings.from_params({**config["tracking"], "lock_treshold": 0.9})
    assert "\n" not in str(err.value)
    partial = {k: v for k, v in config["tracking"].items() if k != "slip_settle_s"}
    with pytest.raises(ConfigError, match=r"^tracking\.slip_settle_s: missing") as err:
        TrackingSettings.from_params(partial, require=EXPERIMENT_KEYS)
    assert "\n" not in str(err.value)
    with pytest.raises(ConfigError, match=r"^tracking\.cn0_windw: not a tracking setting"):  # a scenario's own override
        effective_tracking({"tracking": {"cn0_windw": 5}}, config["tracking"])
