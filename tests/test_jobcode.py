"""A job runs only the code its rule was planned with, and its results record what ran (scintrack.jobcode)."""

from __future__ import annotations

import shutil
import subprocess

import pytest
from conftest import REPO, snakemake_cmd, snakemake_env

from scintrack import io, jobcode
from scintrack.codeversion import clear_caches


@pytest.fixture()
def script(tmp_path):
    """A job script outside the package that imports one package module, and its planned code."""
    path = tmp_path / "job.py"
    path.write_text("from scintrack.seeding import stable_key\n\nVALUE = 1\n")
    clear_caches()
    yield path, jobcode.planned(tmp_path, "job.py", "scintrack.seeding")
    io.JOB.clear()  # the test's own process is not a job


def test_unchanged_code_starts_and_records_the_version_and_the_git_state_at_the_start(script, monkeypatch):
    path, code = script
    jobcode.start(code, path.parent, {"git_commit": "abc", "git_dirty": False})
    monkeypatch.setattr(io, "git_state", lambda *a, **k: {"git_commit": "later", "git_dirty": True})  # a commit during the run
    attrs = io.provenance(config={"a": 1})
    assert attrs["code_version"] == code["version"] and attrs["git_commit"] == "abc" and attrs["git_dirty"] == 0


def test_a_comment_is_not_a_change_but_code_is(script):
    path, code = script
    path.write_text(path.read_text() + "# a comment\n")
    jobcode.start(code, path.parent, {"git_commit": "abc", "git_dirty": False})
    path.write_text(path.read_text() + "VALUE = 2\n")
    with pytest.raises(jobcode.CodeChanged, match="source changed during the run"):
        io.confirm_job_code()
    with pytest.raises(jobcode.CodeChanged, match="at the job's start"):
        jobcode.start(code, path.parent, {"git_commit": "abc", "git_dirty": False})


def test_no_output_is_written_after_the_code_changed(script, tmp_path):
    path, code = script
    jobcode.start(code, path.parent, {"git_commit": "abc", "git_dirty": False})
    path.write_text(path.read_text() + "VALUE = 3\n")
    with pytest.raises(jobcode.CodeChanged):
        io.write_text("result", tmp_path / "out.txt")
    assert not (tmp_path / "out.txt").exists()


@pytest.mark.pipeline
def test_a_job_refuses_to_run_code_other_than_its_plan(smoke_run, tmp_path):
    """A module edited after the DAG was planned: the plan is made from a copy with the edit, the job imports the
    package as installed.  The job ends with one line and writes no figure."""
    repo = tmp_path / "repo"
    ignore = shutil.ignore_patterns("__pycache__", ".snakemake")
    for name in ("workflow", "config", "src"):
        shutil.copytree(REPO / name, repo / name, ignore=ignore)
    shutil.copytree(REPO / "data", repo / "data", ignore=shutil.ignore_patterns("raw", "synthetic", "manifest.json"))
    shutil.copy2(REPO / "Snakefile", repo / "Snakefile")
    module = repo / "src" / "scintrack" / "products" / "figures" / "vila_valls_2018.py"
    module.write_text(module.read_text() + "\nEDITED_AFTER_PLANNING = 1\n")
    work = tmp_path / "work"
    diag = "results/vila_valls_2018/ar_diagnostics.nc"
    (work / diag).parent.mkdir(parents=True)
    shutil.copy2(smoke_run / diag, work / diag)
    cmd = [*snakemake_cmd(), "fig01", "-s", str(repo / "Snakefile"), "--directory", str(work), "--configfile", str(repo / "config" / "smoke.yaml"),
           "--cores", "1", "--allowed-rules", "fig01"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=snakemake_env())
    assert proc.returncode != 0
    lines = [line for line in (proc.stdout + proc.stderr).splitlines() if line.startswith("error: source changed during the run")]
    assert len(lines) == 1, proc.stderr[-3000:]
    assert not list((work / "figures").rglob("fig01*"))
