"""Reproducibility, measured: jobs run again with ONE core, in a fresh folder
that holds only their declared inputs, give the same dataset and result
content hashes, IQ recordings and table and figure bytes as the smoke DAG
built with two cores in another folder; the archive built twice has one
sha256; the verify rule passes on it.

The one-core build covers one output of *every* computing rule of the smoke
DAG (taken from the smoke run's own ``--detailed-summary``, so a new rule is
covered the day it is added; of the experiment rules, which differ only in
their params, two: one with one block of trials and one with several) plus
one figure and one table (every product is drawn by the same two render
scripts).  The fresh folder gets, copied from the
smoke run with their modification times, only the files these jobs declare as
inputs (not the targets themselves); Snakemake then runs each target's job
and whatever a rebuilt target feeds on the way (the Zhao chain rebuilds its
four channels after its dataset), with ``--rerun-triggers`` without ``mtime`` so that copied inputs
older or newer than nothing do not matter.  A job that read a file it does not
declare would find it missing here, so this also checks the declared inputs.
Building every upstream job again, or the whole DAG, would add suite time for
no rule not already covered.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import time

import pytest
from conftest import REPO, run_snakemake, run_targets, snakemake_cmd, snakemake_env

from scintrack.io import content_hash, open_dataset
from scintrack.products import products

pytestmark = pytest.mark.pipeline

ALLOW_DIRTY = REPO / "config" / "allow-dirty.yaml"
#: rules that only collect or check other outputs (covered by their own tests)
AGGREGATES = {"all", "compare", "gallery", "archive", "verify", "figure_checksums", "table_checksums", "dataset_manifest"}
PRODUCTS_BUILT = ("fig01", "table01")
#: the experiment rules built (every experiment is the same rule with other params): one scenario in one block,
#: and three scenarios in blocks merged exactly
EXPERIMENT_RULES = ("tracking_case1_free", "tracking_cycle_slips")
#: Snakemake's rerun triggers but mtime: a copied input has its own modification time
TRIGGERS = ("params", "code", "input", "software-env")
#: what the build's written files are compared by (benchmarks and logs differ by nature)
COMPARED = ("data", "results", "tables", "figures")


def _detailed_summary(workdir) -> dict[str, tuple[str, list[str]]]:
    """output file -> (rule, declared input files of its job) of the smoke DAG in ``workdir`` (``--detailed-summary``)."""
    cmd = [*snakemake_cmd(), "-s", str(REPO / "Snakefile"), "--directory", str(workdir), "--configfile", str(REPO / "config" / "smoke.yaml"),
           "--detailed-summary"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=snakemake_env())
    assert proc.returncode == 0, proc.stderr[-2000:]
    out: dict[str, tuple[str, list[str]]] = {}
    for line in proc.stdout.splitlines()[1:]:  # output_file, date, rule, log-file(s), input-file(s), ...
        cols = line.split("\t")
        if len(cols) >= 5:
            out[cols[0]] = (cols[2], [f for f in cols[4].split(",") if f and f != "-"])
    return out


@pytest.fixture(scope="module")
def one_core_run(smoke_run, tmp_path_factory):
    """Fresh folder with only the declared inputs, ``--cores 1``: one output of every computing rule, fig01, table01."""
    summary = _detailed_summary(smoke_run)
    by_rule: dict[str, list[str]] = {}
    for path, (rule, _) in summary.items():
        by_rule.setdefault(rule, []).append(path)
    names = set(products())
    computing = sorted(r for r in by_rule if r not in AGGREGATES and r not in names
                       and (not r.startswith("tracking_") or r in EXPERIMENT_RULES))
    targets = [sorted(f for f in by_rule[r] if (smoke_run / f).exists())[0] for r in computing if any((smoke_run / f).exists() for f in by_rule[r])]
    built = set(targets) | {f for r in PRODUCTS_BUILT for f in by_rule[r]}
    workdir = tmp_path_factory.mktemp("one_core")
    for rel in sorted({i for f in built for i in summary[f][1]} - built):
        if not os.path.isabs(rel) and (smoke_run / rel).exists():  # repository files (absolute) and temporary shards stay out
            (workdir / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(smoke_run / rel, workdir / rel)
    copied = {p: p.stat().st_mtime_ns for p in workdir.rglob("*") if p.is_file()}
    started = time.time_ns()
    proc = run_snakemake(workdir, "--cores", "1", *targets, *PRODUCTS_BUILT, "--rerun-triggers", *TRIGGERS, "-q")
    assert proc.returncode == 0, proc.stderr[-3000:]
    written = sorted(str(p.relative_to(workdir)) for root in COMPARED for p in (workdir / root).rglob("*")
                     if p.is_file() and "benchmarks" not in p.parts and p.stat().st_mtime_ns >= started)
    return workdir, computing, built, written, copied, summary


def test_one_core_build_equals_the_two_core_smoke_run(smoke_run, one_core_run):
    workdir, computing, built, written, copied, summary = one_core_run
    assert len(computing) >= 20 and {"tracking_cycle_slips", "zhao_channel", "vv_floors", "trace_tracking"} <= set(computing)
    assert set(written) >= built  # every target (and every output of fig01/table01) was written by this run
    covered = {summary[p][0] for p in written if p in summary}
    assert set(computing) <= covered, set(computing) - covered
    assert copied and all(p.stat().st_mtime_ns == t for p, t in copied.items() if str(p.relative_to(workdir)) not in written)
    kinds = {"nc": 0, "bin": 0, "other": 0}
    for rel in written:
        a, b = workdir / rel, smoke_run / rel
        if a.suffix == ".nc":
            assert content_hash(open_dataset(a)) == content_hash(open_dataset(b)), rel
            kinds["nc"] += 1
        else:  # IQ recordings and their sidecars, tables, figures, the manifest-like JSON: the same bytes
            assert a.read_bytes() == b.read_bytes(), rel
            kinds["bin" if a.suffix == ".bin" else "other"] += 1
    assert kinds["nc"] > 10 and kinds["bin"] == 2 and kinds["other"] >= 4, kinds
    assert any("gps_jamming" in p for p in written)


def test_archive_twice_same_sha256_and_verify_passes(smoke_run):
    first = run_targets(smoke_run, "archive", "-q", overlays=[ALLOW_DIRTY])
    assert first.returncode == 0, first.stderr[-3000:]
    (bundle,) = (smoke_run / "archive").glob("*.tar.gz")
    digest = hashlib.sha256(bundle.read_bytes()).hexdigest()
    again = run_targets(smoke_run, "archive", "--forcerun", "archive", "-q", overlays=[ALLOW_DIRTY])
    assert again.returncode == 0, again.stderr[-3000:]
    assert hashlib.sha256(bundle.read_bytes()).hexdigest() == digest
    ver = run_targets(smoke_run, "verify", "-q", overlays=[ALLOW_DIRTY])
    assert ver.returncode == 0, ver.stderr[-3000:]
    assert next((smoke_run / "archive").glob("*.verify.txt")).read_text().startswith("OK ")
