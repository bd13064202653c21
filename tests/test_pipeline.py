"""The smoke DAG end to end: outputs, checksums, per-figure targets, lint."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import pandas as pd
import pytest
from conftest import REPO, run_snakemake, snakemake_cmd, snakemake_env

from scintrack.checksums import read_checksums
from scintrack.io import content_hash, open_dataset, sha256_file

pytestmark = pytest.mark.pipeline

FIGS = [
    "fig01_csm_amplitude_psd_ar", "fig02_csm_amplitude_pacf", "fig03_csm_phase_psd_ar", "fig04_csm_phase_pacf",
    "fig06_rmse_free_and_ssm_equivalence", "fig07_rmse_severe_moderate", "fig08_rmse_ar_mismatch", "fig09_rmse_time_varying", "fig16_cycle_slip_examples",
]
TABLES = ["table01_ar_orders", "table01_ar_orders_vs_paper", "table01s_pacf_order_vs_length", "table02_ssm_equivalence", "table03_steady_state_rmse",
          "table03_steady_state_rmse_vs_paper", "table04_ar_mismatch_vs_paper", "table07_cycle_slips_vs_paper", "tableS1_ar_world", "tableS2_q_sensitivity"]


def test_smoke_outputs_exist_and_checksums_hold(smoke_run):
    fig_dir = smoke_run / "figures"
    sums = read_checksums(fig_dir / "SHA256SUMS")
    for stem in FIGS:
        for ext in ("pdf", "png"):
            rel = f"vila_valls_2018/{stem}.{ext}"
            assert sums[rel] == sha256_file(fig_dir / rel)
    tab_sums = read_checksums(smoke_run / "tables" / "SHA256SUMS")
    on_disk = {p.relative_to(smoke_run / "tables").as_posix() for p in (smoke_run / "tables").rglob("*.*") if p.name != "SHA256SUMS" and not p.name.startswith(".")}
    assert set(tab_sums) == on_disk
    for stem in TABLES:
        assert f"vila_valls_2018/{stem}.csv" in tab_sums and f"vila_valls_2018/{stem}.md" in tab_sums
    for rel, digest in tab_sums.items():
        assert digest == sha256_file(smoke_run / "tables" / rel)


def test_results_carry_provenance_and_valid_content_hash(smoke_run):
    lut = open_dataset(smoke_run / "results" / "ar_models" / "ar_lut.nc")
    for key in ("scintrack_version", "git_commit", "config_sha256", "input_sha256", "content_sha256"):
        assert key in lut.attrs
    assert lut.attrs["content_sha256"] == content_hash(lut)
    assert set(lut["coef"].dims) == {"s4", "tau0", "component", "order", "lag"}
    # zero padding beyond the order, a real coefficient at the order
    coef = lut["coef"].sel(component="amplitude", order=2)
    assert (coef.sel(lag=slice(3, None)) == 0).all() and (coef.sel(lag=2) != 0).all()


def test_manifest_lists_every_dataset_with_checksums(smoke_run):
    manifest = json.loads((smoke_run / "data" / "manifest.json").read_text())
    entries = manifest["datasets"]
    # 3 CSM training sets + 3 surrogate events (no real traces configured) + the jammed GPS scenario + its 2 IQ recordings
    # + the 2 Susi 2014 surrogate traces + the 2 traces of the real-index event
    assert len(entries) == 13
    for e in entries:
        path = smoke_run / e["path"]
        assert e["sha256"] == sha256_file(path)
        assert re.fullmatch(r"v[0-9a-f]{12}", e["dataset_version"])
        assert e["dataset_version"] in (path.stem, path.parent.name)
    recordings = [e for e in entries if e["dataset_name"] == "gps_jamming_iq"]
    assert sorted(Path(e["path"]).name for e in recordings) == ["clean.bin", "jammed.bin"]
    assert all(e["sidecar_sha256"] == sha256_file(smoke_run / e["sidecar"]) for e in recordings)
    (scenario,) = [e for e in entries if e["dataset_name"] == "gps_jamming"]
    assert scenario["params"]["prns"] == [1, 11, 28, 30] and scenario["source"].startswith("synthetic")
    csm = [e for e in entries if e["dataset_name"].startswith("csm_train")]
    surrogate = [e for e in entries if e["dataset_name"].startswith("surrogate_event")]
    susi = [e for e in entries if e["dataset_name"].startswith("surrogate_susi_")]
    assert sorted(e["params"]["event"] for e in susi) == ["susi_equatorial", "susi_high_latitude"]
    assert all(e["source"] == "surrogate" and e["path"].startswith("data/synthetic/susi_surrogate_") for e in susi)
    assert sorted(e["params"]["s4"] for e in csm) == [0.3, 0.5, 0.9]
    assert sorted(e["params"]["event"] for e in surrogate) == ["event1", "event2", "event3"]
    assert all(e["source"] == "surrogate" for e in surrogate)


def test_table01_twin_has_every_region_and_the_paper_column(smoke_run):
    long = pd.read_csv(smoke_run / "tables" / "vila_valls_2018" / "table01_ar_orders.csv")
    assert set(long.region) == {"severe", "moderate", "low"}
    severe_phase = long[(long.region == "severe") & (long.component == "phase")]
    assert set(severe_phase.paper_order) == {1}
    twin = (smoke_run / "tables" / "vila_valls_2018" / "table01_ar_orders_vs_paper.md").read_text()
    assert "q paper" in twin and "p PACF" in twin


def test_one_figure_builds_only_what_it_needs(tmp_path):
    proc = run_snakemake(tmp_path, "-n", "fig01")
    assert proc.returncode == 0, proc.stderr[-2000:]
    jobs = proc.stdout
    assert re.search(r"^fig01\s+1$", jobs, re.M)
    # the two S4 values of the figure's cases, not the whole grid, and no look-up table
    assert re.search(r"^csm_training_set\s+2$", jobs, re.M)
    assert re.search(r"^ar_fit\s+2$", jobs, re.M)
    for other in ("fig02", "fig03", "fig04", "table01", "dataset_manifest", "ar_lut"):
        assert not re.search(rf"^{other}\s", jobs, re.M), other


def test_rerun_is_a_no_op(smoke_run):
    proc = run_snakemake(smoke_run, "-n")
    assert proc.returncode == 0
    assert "Nothing to be done" in proc.stdout + proc.stderr


def test_lint_reports_only_missing_conda_envs():
    import subprocess

    proc = subprocess.run([*snakemake_cmd(), "-s", str(REPO / "Snakefile"), "--lint"], capture_output=True, text=True, cwd=REPO,
                          env=snakemake_env())
    items = [line.strip() for line in (proc.stdout + proc.stderr).splitlines() if line.lstrip().startswith("* ")]
    assert items, "snakemake --lint printed no lint at all (expected the conda/container ones)"
    assert all("conda environment or container" in item for item in items), items


def test_experiment_results_have_statistics_and_twins(smoke_run):
    res = open_dataset(smoke_run / "results" / "experiments" / "cycle_slips" / "slips_case3.nc")
    assert int(res["n_trials"]) == 4 and res.sizes["trial"] == 4  # two shards merged
    assert res.attrs["content_sha256"] == content_hash(res)
    assert (res["rmse_lo"] <= res["rmse"]).all() and (res["rmse"] <= res["rmse_hi"]).all()
    twin = pd.read_csv(smoke_run / "tables" / "vila_valls_2018" / "table03_steady_state_rmse_vs_paper.csv")
    assert {"paper", "reproduced", "ci95_lo", "ci95_hi", "ratio_reproduced_over_paper"} <= set(twin.columns)
    assert len(twin) == 30


def test_jobs_run_with_the_snakefiles_allocator_setting(smoke_run):
    """The Snakefile sets GLIBC_TUNABLES for its jobs (glibc keeps freed memory for reuse,
    docs/performance.md); every job's log records the value it ran with (a user's own setting wins)."""
    match = re.search(r'os\.environ\.setdefault\("GLIBC_TUNABLES", "([^"]+)"\)', (REPO / "Snakefile").read_text())
    assert match, "the Snakefile no longer sets GLIBC_TUNABLES"
    expected = os.environ.get("GLIBC_TUNABLES", match.group(1))
    lines = [line for log in (smoke_run / "logs").rglob("*.log") for line in log.read_text().splitlines() if "GLIBC_TUNABLES=" in line]
    assert len(lines) > 100  # the smoke DAG's script jobs
    assert all(line.endswith(f"GLIBC_TUNABLES={expected}") for line in lines), lines[:3]
