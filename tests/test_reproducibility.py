"""Reproducibility, measured: the smoke DAG built twice in two fresh folders
gives identical dataset and result content hashes, identical IQ recordings and
identical table and figure bytes; the jammed GPS chain built with one core
gives the same as with two;
the archive built twice has one sha256; the verify rule passes on it."""

from __future__ import annotations

import hashlib

import pytest
from conftest import REPO, run_snakemake, run_targets

from scintrack.io import content_hash, open_dataset

pytestmark = pytest.mark.pipeline

ALLOW_DIRTY = REPO / "config" / "allow-dirty.yaml"


@pytest.fixture(scope="module")
def second_run(tmp_path_factory):
    workdir = tmp_path_factory.mktemp("smoke2")
    proc = run_snakemake(workdir, "-q")
    assert proc.returncode == 0, proc.stderr[-3000:]
    return workdir


def _files(root, folder, patterns):
    return sorted(p.relative_to(root) for pat in patterns for p in (root / folder).rglob(pat))


def test_two_fresh_runs_agree(smoke_run, second_run):
    results = _files(smoke_run, "results", ["*.nc"])
    assert len(results) > 20 and results == _files(second_run, "results", ["*.nc"])
    for rel in results:
        assert content_hash(open_dataset(smoke_run / rel)) == content_hash(open_dataset(second_run / rel)), rel
    datasets = _files(smoke_run, "data/synthetic", ["*.nc"])
    assert any("gps_jamming" in str(p) for p in datasets) and datasets == _files(second_run, "data/synthetic", ["*.nc"])
    for rel in datasets:
        assert content_hash(open_dataset(smoke_run / rel)) == content_hash(open_dataset(second_run / rel)), rel
    recordings = _files(smoke_run, "data/synthetic", ["*.bin"])
    assert len(recordings) == 2 and recordings == _files(second_run, "data/synthetic", ["*.bin"])
    for rel in recordings:
        assert (smoke_run / rel).read_bytes() == (second_run / rel).read_bytes(), rel
    outputs = _files(smoke_run, "tables", ["*.csv", "*.md", "*.html"]) + _files(smoke_run, "figures", ["*.png", "*.pdf"])
    assert len(outputs) > 50 and outputs == _files(second_run, "tables", ["*.csv", "*.md", "*.html"]) + _files(second_run, "figures", ["*.png", "*.pdf"])
    for rel in outputs:
        assert (smoke_run / rel).read_bytes() == (second_run / rel).read_bytes(), rel


def test_gps_chain_with_one_core_equals_two_cores(smoke_run, tmp_path):
    proc = run_snakemake(tmp_path, "--cores", "1", "zhao_cn0_estimates", "gps_iq_recording", "-q")
    assert proc.returncode == 0, proc.stderr[-3000:]
    nc = _files(tmp_path, "data/synthetic", ["*.nc"]) + _files(tmp_path, "results", ["*.nc"])
    assert len(nc) == 2
    for rel in nc:
        assert content_hash(open_dataset(tmp_path / rel)) == content_hash(open_dataset(smoke_run / rel)), rel
    for rel in _files(tmp_path, "data/synthetic", ["*.bin"]):
        assert (tmp_path / rel).read_bytes() == (smoke_run / rel).read_bytes(), rel


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
