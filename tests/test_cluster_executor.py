"""Scale-out without code change: part of the smoke DAG through a cluster executor.

``fig16`` needs the three ``cycle_slips`` results of the smoke config (one
job, ``tracking_cycle_slips``, two blocks of trials per scenario) and the AR
look-up table.  The look-up table is taken from the session's smoke run
(copied with its modification time, so Snakemake sees it up to date); the
experiment's job and the figure are built here with Snakemake's generic
cluster executor, whose submit command is ``tests/cluster/submit.sh`` (a
stand-in for sbatch: it records each submission and starts the job script in
the background as a process of its own).  Every job must be submitted with
the threads and resources its rule declares (``scintrack.pipeline.resources``)
and the results must equal the same targets of the smoke DAG, which the local
executor built with the same config in the session's smoke run.
"""

from __future__ import annotations

import collections
import shlex
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import REPO, snakemake_cmd, snakemake_env

from scintrack.config import load_config
from scintrack.io import content_hash, open_dataset
from scintrack.pipeline import resources as R

pytestmark = pytest.mark.pipeline

SUBMIT = REPO / "tests" / "cluster" / "submit.sh"
SMOKE = load_config([REPO / "config" / "config.yaml", REPO / "config" / "smoke.yaml"])
EXPERIMENT = "cycle_slips"  # the smoke experiment with more than one block of trials per scenario
TARGETS = ("fig16",)  # Fig. 16 reads the experiment's three results
DEFAULTS = {"mem_mb": 1000, "runtime": 10}  # --default-resources: the rules that declare none
LUT = Path("results/ar_models/ar_lut.nc")  # copied from the smoke run (see the module docstring)
SCENARIOS = SMOKE["experiments"][EXPERIMENT]["scenarios"]
RESULTS = [Path("results/experiments") / EXPERIMENT / f"{s}.nc" for s in SCENARIOS]


def snakemake(workdir: Path, *args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    """Build TARGETS in ``workdir`` with the smoke overlay (--configfile last: it takes every following word)."""
    cmd = [*snakemake_cmd(), *TARGETS, "-s", str(REPO / "Snakefile"), "--directory", str(workdir), *args,
           "--configfile", str(REPO / "config" / "smoke.yaml")]
    env = snakemake_env()
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)


def declared(rule: str, output: str) -> tuple[int, int, int]:
    """(threads, mem_mb, runtime) that ``rule`` declares for the job writing ``output``."""
    if rule == f"tracking_{EXPERIMENT}":
        return 1, R.experiment_mem_mb(SMOKE, EXPERIMENT), R.experiment_runtime(SMOKE, EXPERIMENT)
    if rule in R.MEASURED:
        return 1, R.mem_mb(rule), R.runtime(rule)
    return 1, DEFAULTS["mem_mb"], DEFAULTS["runtime"]


def expected_jobs() -> collections.Counter:
    spec = SMOKE["experiments"][EXPERIMENT]
    assert int(spec["shards"]) > 1
    return collections.Counter({f"tracking_{EXPERIMENT}": 1, "fig16": 1})


def assert_same_dataset(a: Path, b: Path) -> None:
    x, y = open_dataset(a), open_dataset(b)
    assert content_hash(x) == content_hash(y), a
    assert sorted(x.variables) == sorted(y.variables), a
    for name in x.variables:
        u, v = x[name].values, y[name].values
        assert u.dtype == v.dtype and np.array_equal(u, v, equal_nan=u.dtype.kind in "fc"), (a, name)


@pytest.fixture(scope="module")
def builds(tmp_path_factory, smoke_run):
    """The targets built by the cluster executor, and the smoke run (the local executor, same config)."""
    cluster, local = tmp_path_factory.mktemp("cluster"), smoke_run
    (cluster / LUT).parent.mkdir(parents=True, exist_ok=True)
    shutil.copy2(local / LUT, cluster / LUT)  # the smoke run's file, its mtime kept: up to date
    log = cluster / "submissions" / "jobs.tsv"
    log.parent.mkdir()
    submit = f"bash {shlex.quote(str(SUBMIT))} {shlex.quote(str(log))} {{rule}} {{threads}} {{resources.mem_mb}} {{resources.runtime}} '{{output}}'"
    proc = snakemake(cluster, "--executor", "cluster-generic", "--cluster-generic-submit-cmd", submit, "--jobs", "4",
                     "--seconds-between-status-checks", "1", "--latency-wait", "10",
                     "--default-resources", *(f"{k}={v}" for k, v in DEFAULTS.items()))
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    rows = [line.split("\t") for line in log.read_text().splitlines()]
    return cluster, local, rows


def test_every_job_is_submitted_once_as_its_own_process(builds):
    cluster, _, rows = builds
    assert collections.Counter(r[1] for r in rows) == expected_jobs()
    assert len({r[0] for r in rows}) == len(rows)  # one job id per submission
    for job_id, *_ in rows:  # each ran as its own process, with its own output
        assert (cluster / "submissions" / f"{job_id}.out").exists(), job_id
    (experiment_row,) = [r for r in rows if r[1] == f"tracking_{EXPERIMENT}"]
    assert sorted(experiment_row[5].split()) == sorted(map(str, RESULTS))


def test_jobs_submitted_with_declared_resources(builds):
    _, _, rows = builds
    for _, rule, threads, mem_mb, runtime, output in rows:
        assert (int(threads), int(mem_mb), int(runtime)) == declared(rule, output.split()[0]), (rule, output)
    # the declarations are not the defaults: the resources came from the rules
    assert all(declared(r[1], r[5])[1:] != (DEFAULTS["mem_mb"], DEFAULTS["runtime"]) for r in rows if r[1] in R.MEASURED or r[1].startswith("tracking_"))


def test_cluster_results_equal_local_results(builds):
    cluster, local, _ = builds
    for rel in RESULTS:
        assert_same_dataset(cluster / rel, local / rel)
    assert (cluster / LUT).stat().st_mtime_ns == (local / LUT).stat().st_mtime_ns  # the copied file was not rebuilt
    assert not (cluster / "data").exists()
    figure = sorted(p.relative_to(local) for p in (local / "figures").rglob("fig16_*.png"))
    assert len(figure) == 1
    assert (cluster / figure[0]).read_bytes() == (local / figure[0]).read_bytes()
    assert not list((cluster / "results" / "experiments" / EXPERIMENT).rglob("shard-*.nc"))  # blocks live in a temporary folder only
