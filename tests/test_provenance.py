"""Provenance that cannot lie, and a DAG that a fresh clone can plan.

* ``snakemake -n archive`` in a fresh copy of the repository plans the whole
  DAG (the checksum manifests are outputs of declared rules);
* results record the hash of exactly the config values they depend on;
  ``archive`` refuses, naming the result, a result computed with other
  values, and ``verify`` reports a bundle whose config does not match its
  results.
"""

from __future__ import annotations

import copy
import json
import re
import shutil
import subprocess

import pytest
import yaml
from conftest import REPO, experiment_jobs, run_targets, snakemake_cmd, snakemake_env

from scintrack.archive.build import ArchiveRefused, check_results_config
from scintrack.archive.tarball import SUMS, sums_text
from scintrack.archive.verify import verify
from scintrack.config import load_config
from scintrack.io import hash_object, open_dataset
from scintrack.pipeline import params, paths
from scintrack.products import products

pytestmark = pytest.mark.pipeline
ALLOW_DIRTY = REPO / "config" / "allow-dirty.yaml"


def _jobs(text: str) -> dict[str, int]:
    return {m.group(1): int(m.group(2)) for m in re.finditer(r"^(\w+)\s+(\d+)$", text, re.M) if m.group(1) != "total"}


def test_fresh_clone_plans_the_whole_dag_for_archive(tmp_path):
    clone = tmp_path / "clone"
    files = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"], cwd=REPO, capture_output=True, text=True, check=True)
    for rel in files.stdout.splitlines():
        if (REPO / rel).is_file():
            (clone / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(REPO / rel, clone / rel)
    cmd = [*snakemake_cmd(), "-s", str(clone / "Snakefile"), "--directory", str(clone), "--cores", "2", "-n", "archive"]
    archive = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=snakemake_env())
    assert archive.returncode == 0, archive.stderr[-3000:]
    planned = _jobs(archive.stdout)
    config = load_config([clone / "config" / "config.yaml"])
    exps = config["experiments"].values()
    expected = {
        "archive": 1, "compare": 1, "gallery": 1, "figure_checksums": 1, "table_checksums": 1, "dataset_manifest": 1,
        "csm_training_set": len(config["ar_training"]["s4"]), "ar_fit": len(config["ar_training"]["s4"]), "ar_lut": 1, "ar_diagnostics": 1,
        "surrogate_event": len(config["real_traces"]["events"]), "trace_diagnostics": 1,
        **{r: len(config["real_traces"]["events"]) for r in ("trace_ar_models", "trace_tracking")},
        **experiment_jobs(config["experiments"]),
        "gps_jamming_dataset": 1, "gps_iq_recording": 1, "zhao_cn0_estimates": 1, "zhao_iq_spectrum": 1,
        "zhao_bit_prediction": 1, "zhao_channel": len(config["gps_jamming"]["prns"]), "zhao_receiver": 1,
        "zhao_cn0_sweep_point": len(config["zhao_receiver"]["cn0_sweep"]["cn0_dbhz"]),
        "zhao_reading_channel": len(config["zhao_readings"]["readings"]) * len(config["gps_jamming"]["prns"]),
        "zhao_reading_receiver": len(config["zhao_readings"]["readings"]),
        **({"zhao_clean_dataset": 1} if any(r.get("scenario") == "clean" for r in config["zhao_readings"]["readings"].values()) else {}),
        "susi_surrogate": sum("surrogate" in t for t in config["susi_2014"]["traces"].values()),
        "susi_index_trace": sum("real_indices" in t for t in config["susi_2014"]["traces"].values()), "susi_indices": len(params.susi_scenarios(config)),
        "vv_floors": 1, "susi_jitter_bound": 1, "susi_biscef_indices": 1,
        "real_acquisition": len(paths.signal_recordings(config)), "real_tracking": len(config["real_signals"]["tracked"]),
        **({"ar_lut_wrapped": 1} if any(e.get("lut") == "wrapped" for e in exps) else {}),
        **({"susi_akf_bandwidth": 1} if params.SUSI_AKF_QJERK_EXPERIMENT in config["experiments"] else {}),
        **({"susi_readings_loops": 1} if params.SUSI_READINGS_EXPERIMENT in config["experiments"] else {}),  # Susi readings U1-U4
        **{name: 1 for name in products()},  # every registered figure and table
    }
    assert planned == expected


@pytest.fixture(scope="module")
def smoke_config():
    return load_config([REPO / "config" / "config.yaml", REPO / "config" / "smoke.yaml"])


def test_results_record_the_hash_of_their_own_params(smoke_run, smoke_config):
    expected = params.results(smoke_config)
    assert len(expected) > 20
    for rel, p in expected.items():
        assert open_dataset(smoke_run / rel).attrs["config_sha256"] == hash_object(p), rel
    # a value no result depends on leaves every hash alone; one that a result depends on changes it
    other = copy.deepcopy(smoke_config)
    other["archive"]["max_result_mb"] = 1.0
    assert params.results(other) == expected
    other["trackers"]["kf_q1"]["q_jerk_hz2_s3"] = 2.0
    changed = {rel for rel, p in params.results(other).items() if p != expected[rel]}
    assert changed == {f"results/experiments/iso_q_sensitivity/{sc}.nc" for sc in smoke_config["experiments"]["iso_q_sensitivity"]["scenarios"]}


def test_archive_check_refuses_a_result_of_another_config(smoke_run, smoke_config, monkeypatch):
    monkeypatch.chdir(smoke_run)
    results = sorted(params.results(smoke_config))
    check_results_config(smoke_config, results)  # the config the tree was built with: accepted
    other = copy.deepcopy(smoke_config)
    other["scenarios"]["free"]["duration_s"] = 5.0
    with pytest.raises(ArchiveRefused, match=r"^archive: results/experiments/case1_free/free\.nc \(computed with config hash \w+, the archived config gives \w+\)"):
        check_results_config(other, results)


def test_archive_rule_refuses_when_results_were_not_rerun(smoke_run, tmp_path):
    overlay = tmp_path / "bandwidth.yaml"
    overlay.write_text(yaml.safe_dump({"tracking": {"pll_bandwidth_hz": 12.0}}))
    # mtime-only triggers keep the old results: the archive must refuse them rather than pack a lie
    proc = run_targets(smoke_run, "archive", "--forcerun", "archive", "--rerun-triggers", "mtime", "-q", overlays=[ALLOW_DIRTY, overlay])
    assert proc.returncode != 0
    lines = [line for line in (proc.stdout + proc.stderr).splitlines() if line.startswith("error: archive: results/")]
    assert lines and "rerun snakemake with this config" in lines[0], proc.stderr[-2000:]


def _bundle(folder, smoke_run, config, rels):
    members = {"config/config.yaml": yaml.safe_dump(config, sort_keys=True).encode()}
    manifest = {"content_sha256": {}, "config_sha256": {}, "included": []}
    for rel in rels:
        ds = open_dataset(smoke_run / rel)
        manifest["content_sha256"][rel] = ds.attrs["content_sha256"]
        manifest["config_sha256"][rel] = ds.attrs["config_sha256"]
        manifest["included"].append(rel)
        members[rel] = (smoke_run / rel).read_bytes()
    members["results_manifest.json"] = json.dumps(manifest).encode()
    members[SUMS] = sums_text(members).encode()
    for name, data in members.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(data)
    return folder


def test_verify_reports_results_that_do_not_match_the_archived_config(smoke_run, smoke_config, tmp_path):
    rels = ["results/ar_models/ar_lut.nc", "results/experiments/case1_free/free.nc"]
    good = _bundle(tmp_path / "good", smoke_run, smoke_config, rels)
    assert verify(good) == []
    other = copy.deepcopy(smoke_config)
    other["scenarios"]["free"]["duration_s"] = 5.0
    bad = _bundle(tmp_path / "bad", smoke_run, other, rels)
    problems = verify(bad)
    assert len(problems) == 1 and problems[0].startswith("CONFIG-DIFFERS results/experiments/case1_free/free.nc"), problems
