"""The Sec. VI-E chain on "real" traces the test writes itself (with correct
and with wrong checksums), and the surrogate default's labelling."""

from __future__ import annotations

import hashlib
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml
from conftest import REPO, registry_text, snakemake_cmd, snakemake_env

from scintrack.data.surrogate import surrogate_event, surrogate_params
from scintrack.io import open_dataset

pytestmark = pytest.mark.pipeline

EVENTS = ("event1", "event2", "event3")


def _snakemake(workdir: Path, overlay: Path, *args: str) -> subprocess.CompletedProcess:
    # targets before --configfile, which takes every following word as a file
    cmd = [*snakemake_cmd(), *args, "-s", str(REPO / "Snakefile"), "--directory", str(workdir), "--cores", "2",
           "--configfile", str(REPO / "config" / "smoke.yaml"), str(overlay)]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=snakemake_env())


def _write_traces(folder: Path) -> dict[str, str]:
    """Small multi-band traces in the documented NPZ layout; returns their sha256."""
    cfg = yaml.safe_load((REPO / "config" / "config.yaml").read_text())
    smoke = yaml.safe_load((REPO / "config" / "smoke.yaml").read_text())
    cfg["real_traces"].update({k: v for k, v in smoke["real_traces"].items() if k != "surrogate"})
    cfg["real_traces"]["surrogate"].update({k: v for k, v in smoke["real_traces"]["surrogate"].items()})
    shas = {}
    for ev in EVENTS:
        ds = surrogate_event(surrogate_params(cfg, ev))
        arrays = {"time": 100.0 + ds["time"].values}
        for b in ds["band"].values:
            arrays[f"amplitude_{b}"] = ds["amplitude"].sel(band=b).values.astype(float)
            arrays[f"phase_{b}"] = ds["phase"].sel(band=b).values.astype(float)
        path = folder / f"{ev}.npz"
        np.savez(path, **arrays)
        shas[ev] = hashlib.sha256(path.read_bytes()).hexdigest()
    return shas


def _overlay(tmp: Path, folder: Path, shas: dict[str, str], **extra) -> Path:
    registry = tmp / "registry.yaml"
    registry.write_text(registry_text({f"jrc_hanoi_{e}": {"sha256": s} for e, s in shas.items()}))
    rt = {"registry": str(registry), "sources": {e: {"path": str(folder / f"{e}.npz")} for e in EVENTS}, **extra}
    overlay = tmp / "overlay.yaml"
    overlay.write_text(yaml.safe_dump({"real_traces": rt}))
    return overlay


@pytest.fixture(scope="module")
def traces(tmp_path_factory):
    folder = tmp_path_factory.mktemp("jrc")
    return folder, _write_traces(folder)


def test_real_traces_with_correct_checksums_feed_the_chain(tmp_path, traces):
    folder, shas = traces
    overlay = _overlay(tmp_path, folder, shas)
    work = tmp_path / "work"
    proc = _snakemake(work, overlay, "tableS3", "table05", "fig12", "-q")
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "SURROGATE" not in proc.stderr
    tab = work / "tables" / "vila_valls_2018"
    s3 = (tab / "tableS3_trace_data.md").read_text()
    assert "real JRC Hanoi traces" in s3 and "surrogate" not in s3.lower()
    assert (tab / "table05_static_tracking_vs_paper.md").exists()
    assert (work / "figures" / "vila_valls_2018" / "fig12_trace_s4.png").exists()
    for ev in EVENTS:
        raw = work / "data" / "raw" / "jrc_hanoi" / f"{ev}.npz"
        assert hashlib.sha256(raw.read_bytes()).hexdigest() == shas[ev]
        ds = open_dataset(work / "data" / "traces" / "real" / f"{ev}.nc")
        assert ds.attrs["source"] == "real" and ds["time"].values[0] == 0.0
    assert open_dataset(work / "results" / "real_traces" / "real" / "static" / "event1.nc").attrs["source"] == "real"


def test_wrong_checksum_stops_the_chain_and_keeps_the_file_aside(tmp_path, traces):
    folder, shas = traces
    bad = dict(shas, event2="0" * 64)
    overlay = _overlay(tmp_path, folder, bad)
    work = tmp_path / "work"
    proc = _snakemake(work, overlay, "tableS3", "-q")
    assert proc.returncode != 0
    assert f"event2.npz: sha256 mismatch: expected {'0' * 64}, got {shas['event2']}" in proc.stderr
    raw = work / "data" / "raw" / "jrc_hanoi"
    assert not (raw / "event2.npz").exists()
    assert (raw / f"event2.npz.rejected-{shas['event2'][:12]}").exists()
    assert not (work / "data" / "traces" / "real" / "event2.nc").exists()
    assert not (work / "tables" / "vila_valls_2018" / "tableS3_trace_data.md").exists()


def test_dry_run_with_a_url_never_touches_the_network(tmp_path, traces):
    folder, shas = traces
    overlay = _overlay(tmp_path, folder, shas)
    cfg = yaml.safe_load(overlay.read_text())
    cfg["real_traces"]["sources"] = {e: {"url": f"http://127.0.0.1:9/{e}.npz"} for e in EVENTS}  # nothing listens there
    overlay.write_text(yaml.safe_dump(cfg))
    work = tmp_path / "work"
    proc = _snakemake(work, overlay, "-n", "tableS3")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "fetch_trace" in proc.stdout
    assert not (work / "data" / "raw").exists()


def test_default_run_says_once_that_it_uses_the_surrogate(tmp_path):
    overlay = tmp_path / "empty.yaml"
    overlay.write_text("{}\n")
    proc = _snakemake(tmp_path / "work", overlay, "-n", "tableS3")
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = [ln for ln in (proc.stdout + proc.stderr).splitlines() if "SURROGATE" in ln]
    assert len(lines) == 1 and "real_traces.sources is empty" in lines[0]
