"""Kill and resume: a job killed in the middle of a write, and a whole run
killed as by a power cut, recover with the README's commands, recompute only
what was incomplete, and leave only valid files and no temporary ones.

Writes are atomic (:mod:`scintrack.atomic`): the test makes every write wait
between its complete temporary file and the rename
(``SCINTRACK_HOLD_BEFORE_RENAME``), so the kill lands mid-write, and the
writer's pid is part of the temporary file's name.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import pytest
from conftest import REPO, SNAKEMAKE

from scintrack.atomic import SUFFIX
from scintrack.io import content_hash, open_dataset

pytestmark = pytest.mark.pipeline

TARGET = "results/ar_models/ar_lut.nc"  # 3 CSM training sets -> 3 AR fits -> the look-up table (smoke sizes)


def _cmd(workdir: Path, *args: str) -> list[str]:
    return [SNAKEMAKE, TARGET, *args, "-s", str(REPO / "Snakefile"), "--directory", str(workdir), "--cores", "1",
            "--configfile", str(REPO / "config" / "smoke.yaml")]


def _env(hold: float | None = None) -> dict[str, str]:
    env = dict(os.environ, PYTHONHASHSEED="0")
    env.pop("SCINTRACK_HOLD_BEFORE_RENAME", None)
    if hold is not None:
        env["SCINTRACK_HOLD_BEFORE_RENAME"] = str(hold)
    return env


def _run(workdir: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(_cmd(workdir, *args), capture_output=True, text=True, timeout=600, env=_env())


def _temps(workdir: Path) -> list[Path]:
    return [p for root in ("data", "results") for p in (workdir / root).rglob(f".*{SUFFIX}")]


def _wait_for_temp(workdir: Path, proc: subprocess.Popen, where: str, timeout: float = 240) -> Path:
    """The first temporary file that appears under ``workdir/where`` while ``proc`` runs."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        found = [p for p in (workdir / where).rglob(f".*{SUFFIX}")] if (workdir / where).exists() else []
        if found:
            return found[0]
        assert proc.poll() is None, "the run ended before the write to be interrupted"
        time.sleep(0.05)
    raise AssertionError(f"no write under {where} within {timeout} s")


def _writer_pid(tmp: Path) -> int:
    """The pid in ``.<name>.<host>-<pid>.<random>.scintrack-tmp``."""
    return int(tmp.name[: -len(SUFFIX)].rsplit(".", 2)[1].rpartition("-")[2])


def _valid(path: Path) -> None:
    """A complete NetCDF whose content still has the hash it was written with."""
    ds = open_dataset(path)
    digest = ds.attrs.pop("content_sha256")
    assert content_hash(ds) == digest, path


def _outputs(workdir: Path) -> dict[Path, int]:
    files = sorted((workdir / "data" / "synthetic").rglob("*.nc")) + sorted((workdir / "results" / "ar_models").rglob("*.nc"))
    return {p: p.stat().st_mtime_ns for p in files}


def test_kill_mid_write_and_resume(tmp_path):
    work = tmp_path / "work"

    # 1. SIGKILL the process of one job while it writes its output (after one training set is done).
    proc = subprocess.Popen(_cmd(work), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=_env(hold=1.0))
    first = _wait_for_temp(work, proc, "data/synthetic")
    time.sleep(1.3)  # the first training set is renamed into place; wait for the second job's write
    end = time.monotonic() + 120
    while True:
        temps = [p for p in _temps(work) if p != first]
        if temps:
            victim = temps[0]
            break
        assert proc.poll() is None and time.monotonic() < end, "no second write to interrupt"
        time.sleep(0.05)
    os.kill(_writer_pid(victim), signal.SIGKILL)
    out, _ = proc.communicate(timeout=300)
    assert proc.returncode != 0, out[-2000:]
    assert victim.exists(), "the killed writer's temporary file should be left behind"
    target = victim.parent / ".".join(victim.name[1:].split(".")[:-3])
    done = _outputs(work)
    assert done and target not in done, "the interrupted output must not exist (atomic write)"
    for path in done:
        _valid(path)

    # 2. Resume: the next run removes the stale temporary file and recomputes only what is missing.
    proc2 = _run(work)
    assert proc2.returncode == 0, proc2.stderr[-3000:]
    assert "removed 1 temporary file(s) left by an interrupted run" in proc2.stderr
    assert not _temps(work)
    after = _outputs(work)
    assert all(after[p] == t for p, t in done.items()), "a finished output was recomputed"
    assert len(after) == 10  # smoke: 3 training sets, their unwrapped and wrapped fits, the look-up table
    for path in after:
        _valid(path)

    # 3. Power cut: kill the whole run (Snakemake and its job) while the table is being written.
    proc3 = subprocess.Popen(_cmd(work, "--forcerun", "ar_lut"), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                             env=_env(hold=30.0), start_new_session=True)
    _wait_for_temp(work, proc3, "results/ar_models")
    os.killpg(proc3.pid, signal.SIGKILL)
    proc3.communicate(timeout=60)
    locked = _run(work)
    assert locked.returncode != 0 and "--unlock" in locked.stderr  # Snakemake's LockException says what to do
    # the README's recovery: --unlock once, then --rerun-incomplete
    assert _run(work, "--unlock").returncode == 0
    before = _outputs(work)
    proc4 = _run(work, "--rerun-incomplete")
    assert proc4.returncode == 0, proc4.stderr[-3000:]
    assert "removed 1 temporary file(s)" in proc4.stderr
    final = _outputs(work)
    lut = work / TARGET
    assert lut in final and all(final[p] == t for p, t in before.items() if p != lut), "only the table may be recomputed"
    assert not _temps(work)
    for path in final:
        _valid(path)
    assert (lut.stat().st_mode & 0o777) == 0o666 & ~_umask()


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
