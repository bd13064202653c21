"""Reproducibility, measured: a fresh folder built with ONE core gives the
same dataset and result content hashes, IQ recordings and table and figure
bytes as the smoke DAG built with two cores in another folder; the archive
built twice has one sha256; the verify rule passes on it.

The one-core build covers one output of *every* computing rule of the smoke
DAG (taken from the smoke run's own ``--summary``, so a new rule is covered
the day it is added) plus one figure and one table (every product is drawn by
the same two render scripts); building the whole DAG a second time would
double the suite's time (issue 14) for no rule not already covered.
"""

from __future__ import annotations

import hashlib
import subprocess

import pytest
from conftest import REPO, SNAKEMAKE, run_snakemake, run_targets

from scintrack.io import content_hash, open_dataset
from scintrack.products import products

pytestmark = pytest.mark.pipeline

ALLOW_DIRTY = REPO / "config" / "allow-dirty.yaml"
#: rules that only collect or check other outputs (covered by their own tests)
AGGREGATES = {"all", "compare", "archive", "verify", "figure_checksums", "table_checksums", "dataset_manifest"}
PRODUCTS_BUILT = ("fig01", "table01")


def _summary(workdir) -> dict[str, list[str]]:
    """rule -> output files of the smoke DAG in ``workdir`` (``snakemake --summary``)."""
    cmd = [SNAKEMAKE, "-s", str(REPO / "Snakefile"), "--directory", str(workdir), "--configfile", str(REPO / "config" / "smoke.yaml"), "--summary"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out: dict[str, list[str]] = {}
    for line in proc.stdout.splitlines()[1:]:
        cols = line.split("\t")
        if len(cols) >= 3:
            out.setdefault(cols[2], []).append(cols[0])
    return out


@pytest.fixture(scope="module")
def one_core_run(smoke_run, tmp_path_factory):
    """Fresh folder, ``--cores 1``: one output of every computing rule (and what it needs), fig01, table01."""
    by_rule = _summary(smoke_run)
    names = set(products())
    computing = sorted(r for r in by_rule if r not in AGGREGATES and r not in names)
    targets = [sorted(f for f in by_rule[r] if (smoke_run / f).exists())[0] for r in computing if any((smoke_run / f).exists() for f in by_rule[r])]
    workdir = tmp_path_factory.mktemp("one_core")
    proc = run_snakemake(workdir, "--cores", "1", *targets, *PRODUCTS_BUILT, "-q")
    assert proc.returncode == 0, proc.stderr[-3000:]
    return workdir, computing


def _files(root, folder, patterns):
    return sorted(p.relative_to(root) for pat in patterns for p in (root / folder).rglob(pat))


def test_one_core_build_equals_the_two_core_smoke_run(smoke_run, one_core_run):
    workdir, computing = one_core_run
    covered = set(_summary(workdir))
    assert set(computing) - {"tracking_shard"} <= covered, set(computing) - covered  # shards are temp: seen through their merges
    assert {"tracking_merge", "tracking_single"} <= covered and len(computing) >= 20
    results = _files(workdir, "results", ["*.nc"])
    assert len(results) > 10
    for rel in results:
        assert content_hash(open_dataset(workdir / rel)) == content_hash(open_dataset(smoke_run / rel)), rel
    datasets = _files(workdir, "data/synthetic", ["*.nc"])
    assert any("gps_jamming" in str(p) for p in datasets)
    for rel in datasets:
        assert content_hash(open_dataset(workdir / rel)) == content_hash(open_dataset(smoke_run / rel)), rel
    recordings = _files(workdir, "data/synthetic", ["*.bin"])
    assert len(recordings) == 2
    for rel in recordings:
        assert (workdir / rel).read_bytes() == (smoke_run / rel).read_bytes(), rel
    outputs = _files(workdir, "tables", ["*.csv", "*.md", "*.html"]) + _files(workdir, "figures", ["*.png", "*.pdf"])
    assert len(outputs) >= 4
    for rel in outputs:
        assert (workdir / rel).read_bytes() == (smoke_run / rel).read_bytes(), rel


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
