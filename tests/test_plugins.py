"""Plug-in tracker types: found by entry point like built-in ones, refused with one line when broken, and their code
in the code versions, the results and the bundle; the example plug-in through the ranking of the smoke config.

Small fake distributions (a ``.dist-info`` folder and a module in a temporary folder) exercise the registry and
the code versions in-process.  The example package (``examples/fll_pll_tracker``) is installed once into a
temporary folder (``pip install --no-deps --no-build-isolation --target``, from a copy: the build writes next to
its sources) that the Snakemake runs see through ``PYTHONPATH``.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import yaml
from conftest import REPO, snakemake_cmd, snakemake_env

from scintrack import codeversion, jobcode
from scintrack.config import load_config
from scintrack.errors import ConfigError
from scintrack.trackers import registry

EXAMPLE = REPO / "examples" / "fll_pll_tracker"
OVERLAY = EXAMPLE / "my_trackers.yaml"
PLUGIN_TYPE = "example_fll_pll"
HOLD = textwrap.dedent('''
    """A plug-in tracker that holds the acquisition phase."""
    from dataclasses import dataclass

    import numpy as np

    from scintrack.trackers.base import Tracker, TrackOutput


    @dataclass
    class Hold(Tracker):
        ts: float
        offset_rad: float = 0.0

        SCHEMA = {"offset_rad": {"type": "number"}}
        TRACKING_KEYS = ("fd0_hz",)
        PROVIDES = frozenset()

        @classmethod
        def from_spec(cls, spec, context):
            return cls(ts=context.ts, offset_rad=float(spec.get("offset_rad", 0.0)))

        @staticmethod
        def label(name, spec):
            return "Hold"

        def run(self, y, init):
            return TrackOutput(theta_d=np.repeat(np.asarray(init.phase)[:, None] + self.offset_rad, y.shape[1], axis=1))
''')


def fake_plugin(site: Path, dist: str, entry: str, module: str, source: str = HOLD, version: str = "1.0") -> Path:
    """A distribution ``dist`` in ``site`` with the entry point ``entry`` (``name = module:attr``) and ``module.py``."""
    info = site / f"{dist.replace('-', '_')}-{version}.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: {version}\n")
    (info / "entry_points.txt").write_text(f"[{codeversion.PLUGIN_GROUP}]\n{entry}\n")
    (site / f"{module}.py").write_text(source)
    return site / f"{module}.py"


@pytest.fixture
def types_restored():
    """Whatever a test registers is gone afterwards (the registry is one per process)."""
    registry.known_types()
    saved = dict(registry._TYPES)
    yield
    registry._TYPES.clear()
    registry._TYPES.update(saved)


# --- the registry ----------------------------------------------------------------------------------------


def test_a_plugin_type_works_like_a_builtin_type(tmp_path, monkeypatch, types_restored):
    fake_plugin(tmp_path, "hold-plugin", "plug_hold = plug_hold_mod:Hold", "plug_hold_mod")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert registry.load_plugins([str(tmp_path)]) == ["plug_hold"]
    assert "plug_hold" in registry.known_types() and not registry.from_package("plug_hold") and registry.from_package("pll")
    assert registry.plugin_of("plug_hold").distribution == "hold-plugin" and registry.plugin_of("pll") is None
    registry.validate_specs({"h": {"type": "plug_hold", "offset_rad": 0.1, "label": "Mine"}}, "my.yaml")
    with pytest.raises(ConfigError, match=r"^invalid config value at 'trackers\.h\.bandwidth_hz': key not allowed for type 'plug_hold'"):
        registry.validate_specs({"h": {"type": "plug_hold", "bandwidth_hz": 3}}, "my.yaml")
    assert registry.label("h", {"type": "plug_hold"}) == "Hold" and registry.tracking_keys({"type": "plug_hold"}) == ("fd0_hz",)
    assert registry.load_plugins([str(tmp_path)]) == ["plug_hold"]  # loading again is the same type, no clash


@pytest.mark.parametrize(("case", "expected"), [
    ("builtin", r"plug-in tracker type 'pll' of the entry point 'pll = clash_mod:Hold' of clash-plugin 1\.0 clashes with the built-in type"),
    ("twice", r"plug-in tracker type 'dup' is declared twice .*'dup = dup_a:Hold' of dup-a 1\.0 and entry point 'dup = dup_b:Hold' of dup-b 1\.0"),
    ("import", r"plug-in tracker type 'broken' fails to import \(ModuleNotFoundError: No module named 'not_installed_anywhere'\): entry point "
               r"'broken = broken_mod:Hold' of broken-plugin 1\.0"),
    ("not_a_tracker", r"plug-in tracker type 'odd': the entry point 'odd = odd_mod:Hold' of odd-plugin 1\.0 names .*not a subclass"),
])
def test_a_broken_plugin_is_one_line_naming_its_distribution_and_entry_point(tmp_path, monkeypatch, types_restored, case, expected):
    if case == "builtin":
        fake_plugin(tmp_path, "clash-plugin", "pll = clash_mod:Hold", "clash_mod")
    elif case == "twice":
        fake_plugin(tmp_path, "dup-a", "dup = dup_a:Hold", "dup_a")
        fake_plugin(tmp_path, "dup-b", "dup = dup_b:Hold", "dup_b")
    elif case == "import":
        fake_plugin(tmp_path, "broken-plugin", "broken = broken_mod:Hold", "broken_mod", source="import not_installed_anywhere\n")
    else:
        fake_plugin(tmp_path, "odd-plugin", "odd = odd_mod:Hold", "odd_mod", source="class Hold:\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(registry.PluginError) as exc:
        registry.load_plugins([str(tmp_path)])
    assert "\n" not in str(exc.value) and re.search(expected, str(exc.value)), str(exc.value)
    assert isinstance(exc.value, ConfigError)  # the workflow's config check turns it into one error: line


def test_snakemake_stops_on_a_clashing_plugin_with_one_error_line(tmp_path):
    site = tmp_path / "site"
    fake_plugin(site, "clash-plugin", "kf = clash_mod:Hold", "clash_mod")
    work = tmp_path / "work"
    work.mkdir()  # fresh: no remembered config check, so the registry is loaded while the DAG is built
    cmd = [*snakemake_cmd(), "-n", "-s", str(REPO / "Snakefile"), "--directory", str(work), "--cores", "1",
           "--configfile", str(REPO / "config" / "smoke.yaml")]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=snakemake_env(PYTHONPATH=str(site)))
    lines = [line for line in proc.stderr.splitlines() if line.startswith("error: ")]
    assert proc.returncode != 0 and "Traceback" not in proc.stderr + proc.stdout, proc.stderr[-2000:]
    assert len(lines) == 1 and "'kf = clash_mod:Hold' of clash-plugin 1.0" in lines[0], proc.stderr[-2000:]


# --- code versions --------------------------------------------------------------------------------------


def test_plugin_code_follows_the_code_not_comments_and_is_empty_for_builtin_types(tmp_path):
    module = fake_plugin(tmp_path, "hold-plugin", "plug_hold = plug_hold_mod:Hold", "plug_hold_mod")
    path = [str(tmp_path)]
    assert codeversion.plugin_code(["pll", "kf"], path) == []
    (first,) = codeversion.plugin_code(["pll", "plug_hold"], path)
    assert first["distribution"] == "hold-plugin" and first["version"] == "1.0" and first["entry_point"] == "plug_hold = plug_hold_mod:Hold"
    module.write_text(module.read_text().replace('"""A plug-in', '"""Edited docs. A plug-in') + "\n# a comment\n")
    codeversion.clear_caches()
    assert codeversion.plugin_code(["plug_hold"], path) == [first]
    module.write_text(module.read_text() + "\nEXTRA = 1\n")
    codeversion.clear_caches()
    (second,) = codeversion.plugin_code(["plug_hold"], path)
    assert second["source_sha256"] != first["source_sha256"]
    assert codeversion.with_plugins("0123456789abcdef", [first]) == (
        f"0123456789abcdef + plug-ins: hold-plugin 1.0 (source sha256 {first['source_sha256'][:16]})")
    assert codeversion.with_plugins("0123456789abcdef", []) == "0123456789abcdef"


def test_a_rule_without_plugin_types_plans_the_code_it_planned_before(tmp_path, monkeypatch):
    fake_plugin(tmp_path, "hold-plugin", "plug_hold = plug_hold_mod:Hold", "plug_hold_mod")
    monkeypatch.syspath_prepend(str(tmp_path))
    codeversion.clear_caches()
    scripts = REPO / "workflow" / "scripts"
    plain = jobcode.planned(scripts, "run_experiment.py")
    assert jobcode.planned(scripts, "run_experiment.py", trackers=["pll", "kf"]) == plain
    with_plugin = jobcode.planned(scripts, "run_experiment.py", trackers=["pll", "plug_hold"])
    assert with_plugin["version"].startswith(plain["version"] + " + plug-ins: hold-plugin 1.0 (source sha256 ")
    assert [p["type"] for p in with_plugin["plugins"]] == ["plug_hold"]
    jobcode.start(with_plugin, scripts, {"git_commit": "x", "git_dirty": False})  # the job's own check agrees with the plan
    from scintrack import io

    assert io.JOB["ran"]["code_version"] == with_plugin["version"]
    io.JOB.clear()


# --- the example plug-in through the smoke ranking ----------------------------------------------------------


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """The example package installed into a temporary folder (from a copy: the build writes beside the sources)."""
    root = tmp_path_factory.mktemp("plugin")
    source = root / "source"
    shutil.copytree(EXAMPLE, source, ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    site = root / "site"
    proc = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation", "--no-index", "--quiet",
                           "--target", str(site), str(source)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    return site


def registry_entry(site: Path) -> codeversion.PluginEntry:
    (entry,) = [e for e in codeversion.plugin_entry_points([str(site)]) if e.name == PLUGIN_TYPE]
    return entry


def _env(site: Path) -> dict[str, str]:
    return {"PYTHONPATH": str(site), "PYTHONDONTWRITEBYTECODE": "1"}


def test_the_example_plugin_passes_its_own_tests(installed):
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-o", "addopts=", "-p", "no:cacheprovider", str(EXAMPLE / "tests")],
                          capture_output=True, text=True, timeout=300, cwd=installed, env=dict(os.environ, **_env(installed)))
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert "3 passed" in proc.stdout


@pytest.fixture(scope="module")
def ranked(installed, tmp_path_factory) -> Path:
    """``snakemake ranking`` with the example overlay on the smoke config, in a fresh folder."""
    work = tmp_path_factory.mktemp("ranked")
    proc = subprocess.run(_ranking_cmd(work, "-q"), capture_output=True, text=True, timeout=900, env=snakemake_env(**_env(installed)))
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return work


def _ranking_cmd(work: Path, *args: str) -> list[str]:
    """The documented command, with the smoke config under the example overlay (targets before --configfile)."""
    return [*snakemake_cmd(), "ranking", *args, "-s", str(REPO / "Snakefile"), "--directory", str(work), "--cores", "2",
            "--configfile", str(REPO / "config" / "smoke.yaml"), str(OVERLAY)]


def _overlay_config():
    return load_config([REPO / "config" / "config.yaml", REPO / "config" / "smoke.yaml", OVERLAY])


def _with_plugin(config) -> set[str]:
    names = {n for n, spec in config["trackers"].items() if spec["type"] == PLUGIN_TYPE}
    return {e for e, spec in config["experiments"].items() if names & set(spec["trackers"])}


@pytest.mark.pipeline
def test_the_ranking_ranks_the_plugin_on_every_scenario_it_ran_and_results_name_its_code(ranked):
    import pandas as pd

    from scintrack.io import read_attrs
    from scintrack.pipeline import paths
    from scintrack.products.tables.ranking import EXPERIMENTS

    config = _overlay_config()
    used = _with_plugin(config)
    assert used and used <= set(EXPERIMENTS)
    table = pd.read_csv(next((ranked / "tables" / "cross_paper").glob("table_ranking_surrogate.csv")))
    mine = table[table["tracker"] == "fll_pll"]
    expected = {sc for e in used for sc in config["experiments"][e]["scenarios"]}
    assert set(mine["scenario"]) == expected and (mine["label"] == "FLL-assisted PLL (FLL 2 Hz)").all()
    assert mine["rank"].notna().all() and (mine["rmse_wrapped_rad"] > 0).all()
    assert (ranked / "figures" / "cross_paper" / "fig_ranking_surrogate.png").is_file()
    for e in EXPERIMENTS:
        for sc in config["experiments"][e]["scenarios"]:
            code = read_attrs(ranked / paths.exp_result(e, sc))["code_version"]
            assert (" + plug-ins: fll-pll-tracker 0.1.0 (source sha256 " in code) == (e in used), (e, sc, code)


def _dry_run(work: Path, site: Path) -> dict[str, int]:
    proc = subprocess.run(_ranking_cmd(work, "-n"), capture_output=True, text=True, timeout=300, env=snakemake_env(**_env(site)))
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    text = proc.stdout + proc.stderr
    if "Nothing to be done" in text:
        return {}
    jobs = {m.group(1): int(m.group(2)) for m in re.finditer(r"^(\w+)\s+(\d+)$", text, re.M)}
    jobs.pop("total", None)
    return jobs


@pytest.mark.pipeline
def test_editing_the_plugin_reruns_exactly_the_experiments_that_run_it(ranked, installed, tmp_path):
    site = tmp_path / "site"
    shutil.copytree(installed, site)  # the installed copy is edited, in a folder of this test only
    module = site / "fll_pll_tracker" / "tracker.py"
    module.write_text(module.read_text() + "\n# a comment: not code\n")
    assert _dry_run(ranked, site) == {}
    module.write_text(module.read_text() + "\nUNUSED = 1\n")
    expected = {f"tracking_{e}": 1 for e in _with_plugin(_overlay_config())}
    assert _dry_run(ranked, site) == {**expected, "table_ranking": 1, "fig_ranking": 1, "ranking": 1}


def test_a_bundle_built_with_the_plugin_names_it_and_verify_prints_it(installed, tmp_path, monkeypatch):
    from scintrack.archive.build import finish
    from scintrack.archive.tarball import write_tarball

    monkeypatch.syspath_prepend(str(installed))
    codeversion.clear_caches()
    config = _overlay_config()
    members = finish({"tables/t.md": b"| a |\n"}, config=config, git={"git_commit": "abc", "git_dirty": False}, timings=[], name="b", version="1")
    (record,) = json.loads(members["provenance.json"])["plugin_trackers"]
    assert record["type"] == PLUGIN_TYPE and record["distribution"] == "fll-pll-tracker" and record["version"] == "0.1.0"
    assert record["source_sha256"] == codeversion.plugin_source_sha256(registry_entry(installed))
    bundle = tmp_path / "b-1.tar.gz"
    write_tarball(members, bundle, root="b-1")
    proc = subprocess.run([sys.executable, "-m", "scintrack", "verify", str(bundle)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    out = proc.stdout.splitlines()
    assert out[0].startswith("OK ") and out[1] == f"plug-in trackers: fll-pll-tracker 0.1.0 (source sha256 {record['source_sha256'][:16]})"
    plain = finish({"tables/t.md": b"| a |\n"}, config=load_config([REPO / "config" / "config.yaml"]), git={"git_commit": "abc", "git_dirty": False},
                   timings=[], name="b", version="1")
    assert "plugin_trackers" not in json.loads(plain["provenance.json"])


def test_the_overlay_is_a_valid_config_layer():
    overlay = yaml.safe_load(OVERLAY.read_text())
    config = load_config([REPO / "config" / "config.yaml", OVERLAY])
    for name in overlay["experiments"]:
        base = load_config([REPO / "config" / "config.yaml"])["experiments"][name]
        assert config["experiments"][name]["trackers"] == [*base["trackers"], "fll_pll"], name  # the config's list plus the plug-in
