"""Shared fixtures: repository paths and one smoke run of the whole DAG per session."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
SNAKEMAKE = str(BIN / "snakemake")


def run_snakemake(workdir: Path, *args: str, timeout: float = 900) -> subprocess.CompletedProcess:
    """Run the repository's Snakefile with the smoke overlay in ``workdir``."""
    cmd = [
        SNAKEMAKE, "-s", str(REPO / "Snakefile"), "--directory", str(workdir),
        "--configfile", str(REPO / "config" / "smoke.yaml"), "--cores", "2", *args,
    ]
    env = dict(os.environ, PYTHONHASHSEED="0")
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)


@pytest.fixture(scope="session")
def smoke_run(tmp_path_factory) -> Path:
    """The smoke DAG built once in a fresh folder; returns that folder."""
    workdir = tmp_path_factory.mktemp("smoke")
    proc = run_snakemake(workdir, "-q")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return workdir


def experiment_jobs(experiments) -> dict[str, int]:
    """Jobs that a set of experiment specs plans: per scenario, ``shards`` tracking_shard jobs and one
    tracking_merge when ``shards > 1``, one tracking_single job otherwise (rules with no job left out)."""
    experiments = list(experiments)
    multi = [e for e in experiments if int(e["shards"]) > 1]
    single = [e for e in experiments if int(e["shards"]) == 1]
    jobs = {"tracking_shard": sum(len(e["scenarios"]) * int(e["shards"]) for e in multi),
            "tracking_merge": sum(len(e["scenarios"]) for e in multi),
            "tracking_single": sum(len(e["scenarios"]) for e in single)}
    return {rule: n for rule, n in jobs.items() if n}


def run_targets(workdir: Path, *targets: str, overlays=(), timeout: float = 600) -> subprocess.CompletedProcess:
    """Build ``targets`` (rule names or files; before --configfile, which takes every following word)."""
    cmd = [SNAKEMAKE, *targets, "-s", str(REPO / "Snakefile"), "--directory", str(workdir), "--cores", "2",
           "--configfile", str(REPO / "config" / "smoke.yaml"), *map(str, overlays)]
    env = dict(os.environ, PYTHONHASHSEED="0")
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
