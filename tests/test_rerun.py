"""Results follow the config and the code: after a complete smoke build, a dry
run schedules exactly the jobs that a change affects, and nothing for a change
that affects no result (a comment in a source file).

Config changes are overlays on the smoke config; code changes are made in a
copy of the workflow and package (file times preserved) run against the same
working directory, so the repository itself is never edited.
"""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest
import yaml
from conftest import REPO, experiment_jobs, run_snakemake, snakemake_cmd, snakemake_env

from scintrack.config import load_config

pytestmark = pytest.mark.pipeline


def planned(proc: subprocess.CompletedProcess) -> dict[str, int]:
    """Job counts of a dry run (the 'job  count' table), without the total."""
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    text = proc.stdout + proc.stderr
    if "Nothing to be done" in text:
        return {}
    jobs = dict((m.group(1), int(m.group(2))) for m in re.finditer(r"^(\w+)\s+(\d+)$", text, re.M))
    jobs.pop("total", None)
    return jobs


def dry_run_with(workdir, tmp_path, overlay: dict) -> dict[str, int]:
    path = tmp_path / "overlay.yaml"
    path.write_text(yaml.safe_dump(overlay))
    return planned(run_snakemake(workdir, "-n", "--configfile", str(REPO / "config" / "smoke.yaml"), str(path)))


@pytest.fixture(scope="module")
def smoke_config():
    return load_config([REPO / "config" / "config.yaml", REPO / "config" / "smoke.yaml"])


def test_tracker_parameter_reruns_only_its_experiments(smoke_run, tmp_path, smoke_config):
    jobs = dry_run_with(smoke_run, tmp_path, {"trackers": {"kf_q1": {"type": "kf", "q_jerk_hz2_s3": 2.0}}})
    exp = smoke_config["experiments"]["iso_q_sensitivity"]  # the only experiment with kf_q1
    assert jobs == {**experiment_jobs({"iso_q_sensitivity": exp}), "tableS2": 1, "table_checksums": 1, "all": 1}


def test_scenario_duration_reruns_only_that_scenario(smoke_run, tmp_path):
    jobs = dry_run_with(smoke_run, tmp_path, {"scenarios": {"free": {"duration_s": 5.0}}})
    assert jobs == {"tracking_case1_free": 1, "fig06": 1, "figure_checksums": 1, "gallery": 1, "all": 1}  # case1_free: one shard


def test_figure_option_reruns_only_its_figures(smoke_run, tmp_path):
    jobs = dry_run_with(smoke_run, tmp_path, {"figures": {"vila_valls_2018": {"welch_nperseg": 128}}})
    assert jobs == {"ar_diagnostics": 1, "fig01": 1, "fig02": 1, "fig03": 1, "fig04": 1, "figure_checksums": 1, "gallery": 1, "all": 1}


def test_zhao_trial_counts_rerun_only_what_reads_them(smoke_run, tmp_path, smoke_config):
    """The channels' trials rerun the channels and what reads them, not the C/N0 sweep; the sweep's trials rerun the
    sweep points and their products, not the channels; neither reruns the bit prediction (it reads neither)."""
    rc = smoke_config["zhao_receiver"]
    sweep = dry_run_with(smoke_run, tmp_path, {"zhao_receiver": {"cn0_sweep": {**rc["cn0_sweep"], "trials": int(rc["cn0_sweep"]["trials"]) + 1}}})
    assert sweep == {"zhao_cn0_sweep_point": len(rc["cn0_sweep"]["cn0_dbhz"]), "zhao_sweep": 1, "zhao_table_cn0_sweep": 1,
                     "figure_checksums": 1, "table_checksums": 1, "gallery": 1, "all": 1}
    one_more = [*rc["cn0_sweep"]["cn0_dbhz"], 33.0]  # a new point runs that point only
    added = dry_run_with(smoke_run, tmp_path, {"zhao_receiver": {"cn0_sweep": {**rc["cn0_sweep"], "cn0_dbhz": one_more}}})
    assert added["zhao_cn0_sweep_point"] == 1 and added["zhao_sweep"] == 1
    channels = dry_run_with(smoke_run, tmp_path, {"zhao_receiver": {"trials": int(rc["trials"]) + 1}})
    assert channels["zhao_channel"] == len(smoke_config["gps_jamming"]["prns"]) and channels["zhao_receiver"] == 1
    assert not {"zhao_cn0_sweep_point", "zhao_bit_prediction", "zhao_sweep", "zhao_table_cn0_sweep"} & set(channels)


def test_pll_bandwidth_reruns_exactly_the_experiments_with_a_pll(smoke_run, smoke_config):
    # given on the command line as a nested value: typed as in a config file ('15.0' -> 15.0)
    jobs = planned(run_snakemake(smoke_run, "-n", "--config", 'tracking={"pll_bandwidth_hz": 15.0}'))
    with_pll = {k: v for k, v in smoke_config["experiments"].items() if "pll" in v["trackers"]}
    assert 0 < len(with_pll) < len(smoke_config["experiments"])
    expected = experiment_jobs(with_pll)
    assert {rule: jobs.get(rule, 0) for rule in expected} == expected
    assert not {f"tracking_{name}" for name in smoke_config["experiments"]} - set(expected) & set(jobs)  # the others do not rerun
    assert jobs["trace_tracking"] == len(smoke_config["real_traces"]["events"])  # the trace trackers include the PLL
    assert "ar_lut" not in jobs and "table04" not in jobs  # case3_mismatch has no PLL


@pytest.fixture()
def code_copy(tmp_path):
    """Snakefile, workflow and package copied with their file times."""
    root = tmp_path / "repo"
    ignore = shutil.ignore_patterns("__pycache__", ".snakemake")
    for name in ("workflow", "config", "src"):
        shutil.copytree(REPO / name, root / name, ignore=ignore)
    (root / "data").mkdir()
    shutil.copy2(REPO / "data" / "registry.yaml", root / "data" / "registry.yaml")
    shutil.copytree(REPO / "data" / "ephemerides", root / "data" / "ephemerides")  # inputs from outside the pipeline
    shutil.copytree(REPO / "data" / "real", root / "data" / "real")
    shutil.copy2(REPO / "Snakefile", root / "Snakefile")
    shutil.copy2(REPO / "environment.lock", root / "environment.lock")
    return root


def dry_run_copy(root, workdir) -> dict[str, int]:
    """Jobs a dry run of the copy plans.  The copy moves the repository's own input (the RINEX file) to another
    absolute path, which Snakemake's input trigger counts as a change; the test is about code, which reaches
    the rules as params (code versions), so the input trigger is left out."""
    cmd = [*snakemake_cmd(), "-s", str(root / "Snakefile"), "--directory", str(workdir), "--configfile", str(root / "config" / "smoke.yaml"), "--cores", "2", "-n",
           "--rerun-triggers", "mtime", "params", "code", "software-env"]
    return planned(subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=snakemake_env()))


def test_comment_in_a_source_file_reruns_nothing_and_code_change_reruns_its_rules(smoke_run, code_copy):
    ar = code_copy / "src" / "scintrack" / "models" / "ar.py"
    ar.write_text(ar.read_text().replace('"""', '"""A docstring edit. ', 1) + "\n# a comment\n")
    runner = code_copy / "src" / "scintrack" / "experiments" / "runner.py"
    runner.write_text(runner.read_text() + "\n\n# another comment\n")
    assert dry_run_copy(code_copy, smoke_run) == {}  # the copy (file times kept) plus comments: up to date
    ar.write_text(ar.read_text() + "\nUNUSED_FOR_THIS_TEST = 1\n")
    jobs = dry_run_copy(code_copy, smoke_run)
    assert jobs.get("trace_ar_models") == 3 and jobs.get("ar_fit") == 3  # both import models/ar.py
    assert "zhao_fig05" not in jobs  # draws the IQ spectrum and C/N0: no AR code involved
