"""repro.py as a user runs it: Ctrl-C, a damaged .venv, a folder with a blank in its path.

Each test copies repro.py into a small fake project (a lock of two packages,
a ``.venv`` whose ``bin/python`` and ``bin/snakemake`` are one Python script
that plays pip, pytest and Snakemake), so no real install happens.  Ctrl-C is
a SIGINT to the whole process group, as a terminal sends it.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SITE = Path(".venv/lib/python3.11/site-packages")
LOCK = """\
# a comment line
fakepkg==1.0 \\
    --hash=sha256:aaaa \\
    --hash=sha256:bbbb
    # via something
Other-Pkg==2.0 \\
    --hash=sha256:cccc
winonly==3.0 ; sys_platform == "win32" \\
    --hash=sha256:dddd
"""
FAKEPKG_RECORD = [
    "fakepkg/__init__.py",
    "fakepkg/core.py",
    "fakepkg/__pycache__/core.cpython-311.pyc",  # listed, never written: bytecode is not checked
    "fakepkg-1.0.dist-info/RECORD",
    "../../../bin/fakecli",
]

# One script for .venv/bin/python and .venv/bin/snakemake.  FAKE_CHILD: what
# pytest/snakemake does (quick: exit FAKE_EXIT; graceful: on SIGINT sleep
# FAKE_SLEEP, write the marker, exit 3; die: SIGINT kills it); FAKE_PIP:
# repair (a forced reinstall restores the files of the packages it names),
# broken (does nothing), block (waits for SIGINT, exits 1 as pip does).
FAKE = r"""#!{python}
import json, os, re, signal, sys, time
from pathlib import Path

root = Path(__file__).resolve().parents[2]
args = sys.argv[1:]
tool = "snakemake" if Path(sys.argv[0]).name == "snakemake" else " ".join(args[:2])
entry = {{"tool": tool, "args": args}}
if tool == "-m pip" and "-r" in args:
    entry["requirements"] = (root / args[args.index("-r") + 1]).read_text()
with open(root / "calls.log", "a") as fh:
    fh.write(json.dumps(entry) + "\n")


def wait_for_ctrl_c(then):
    hits = []
    signal.signal(signal.SIGINT, lambda *_: hits.append(time.monotonic()))
    (root / "ready").write_text("")
    while not hits:
        time.sleep(0.01)
    then(hits)


if tool == "-m pip":
    mode = os.environ.get("FAKE_PIP", "repair")
    if mode == "block":
        wait_for_ctrl_c(lambda hits: sys.exit(1))
    if mode == "repair" and "--force-reinstall" in args:
        site = root / "{site}"
        for name, version in re.findall(r"^(\S+)==(\S+)", entry["requirements"], re.M):
            info = site / f"{{re.sub(r'[-.]', '_', name).lower()}}-{{version}}.dist-info"
            for line in (info / "RECORD").read_text().splitlines():
                path = site / line.split(",")[0]
                if "__pycache__" not in line and not path.exists():
                    path.parent.mkdir(parents=True, exist_ok=True)
                    path.write_text("restored")
    sys.exit(0)

mode = os.environ.get("FAKE_CHILD", "quick")
if mode == "graceful":
    def finish(hits):
        time.sleep(float(os.environ.get("FAKE_SLEEP", "0.6")))
        (root / "child-finished").write_text(json.dumps(len(hits)))
        sys.exit(3)
    wait_for_ctrl_c(finish)
elif mode == "die":
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    (root / "ready").write_text("")
    time.sleep(30)
sys.exit(int(os.environ.get("FAKE_EXIT", "0")))
"""


def digest(root: Path) -> str:
    return hashlib.sha256((root / "environment.lock").read_bytes() + (root / "pyproject.toml").read_bytes()).hexdigest()


def make_project(parent: Path) -> Path:
    """A project folder with repro.py, a two-package lock and an intact, stamped fake .venv."""
    root = parent / "proj"
    site = root / SITE
    (root / "src").mkdir(parents=True)
    shutil.copy(REPO / "repro.py", root / "repro.py")
    (root / "environment.lock").write_text(LOCK)
    (root / "pyproject.toml").write_text('[project]\nname = "scintrack"\n')
    bin_ = root / ".venv" / "bin"
    bin_.mkdir(parents=True)
    for name in ("python", "snakemake"):
        (bin_ / name).write_text(FAKE.format(python=sys.executable, site=SITE))
        (bin_ / name).chmod(0o755)
    records = {
        "fakepkg-1.0.dist-info": FAKEPKG_RECORD,
        "other_pkg-2.0.dist-info": ["other_pkg.py", "other_pkg-2.0.dist-info/RECORD"],
        "scintrack-0.1.0.dist-info": ["__editable__.scintrack-0.1.0.pth", "scintrack-0.1.0.dist-info/RECORD"],
    }
    for info, files in records.items():
        (site / info).mkdir(parents=True)
        (site / info / "RECORD").write_text("".join(f"{f},sha256=x,1\n" for f in files))
        for f in files:
            if "__pycache__" not in f and not (site / f).exists():
                (site / f).parent.mkdir(parents=True, exist_ok=True)
                (site / f).write_text("x")
    (site / "__editable__.scintrack-0.1.0.pth").write_text(f"{root.resolve() / 'src'}\n")
    (root / ".venv" / ".scintrack-env-sha256").write_text(digest(root) + "\n")
    return root


def calls(root: Path) -> list[dict]:
    log = root / "calls.log"
    return [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []


def repro(root: Path, *args: str, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(root / "repro.py"), *args], capture_output=True, text=True, env={**os.environ, **env}, timeout=60
    )


def interrupt(root: Path, args: list[str], presses: int, env: dict[str, str]) -> tuple[int, str]:
    """Start repro.py in its own process group, press Ctrl-C ``presses`` times once the child is ready."""
    proc = subprocess.Popen(
        [sys.executable, str(root / "repro.py"), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, **env},
        start_new_session=True,
    )
    deadline = time.monotonic() + 30
    while not (root / "ready").exists():
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.01)
    for press in range(presses):
        if press:
            time.sleep(0.2)
        os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    return proc.returncode, err


@pytest.fixture
def project(tmp_path: Path) -> Path:
    return make_project(tmp_path)


# ------------------------------------------------------------------ Ctrl-C


@pytest.mark.parametrize("command", ["run", "test"])
def test_ctrl_c_lets_the_child_finish_and_returns_its_exit_code(project: Path, command: str):
    # The child needs 0.6 s after the SIGINT: longer than the 0.25 s
    # subprocess.run gives a child before killing it on KeyboardInterrupt.
    status, err = interrupt(project, [command], 1, {"FAKE_CHILD": "graceful"})
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    assert json.loads((project / "child-finished").read_text()) == 1  # the child got the one SIGINT, from the group
    assert status == 3


def test_second_ctrl_c_keeps_waiting_and_says_so(project: Path):
    status, err = interrupt(project, ["run"], 2, {"FAKE_CHILD": "graceful", "FAKE_SLEEP": "1.0"})
    assert "Traceback" not in err
    assert json.loads((project / "child-finished").read_text()) == 2  # not killed, not sent a third SIGINT
    assert status == 3
    waiting = [line for line in err.splitlines() if "waiting for snakemake to finish stopping" in line]
    assert len(waiting) == 1


def test_child_ended_by_ctrl_c_gives_the_shell_status(project: Path):
    status, err = interrupt(project, ["test"], 1, {"FAKE_CHILD": "die"})
    assert status == 128 + signal.SIGINT
    assert "Traceback" not in err


def test_ctrl_c_during_install_leaves_no_ready_stamp(project: Path):
    stamp = project / ".venv" / ".scintrack-env-sha256"
    with open(project / "environment.lock", "a") as fh:
        fh.write("# the lock changed\n")
    status, err = interrupt(project, ["env"], 1, {"FAKE_PIP": "block"})
    assert status != 0 and "Traceback" not in err
    assert "not marked ready" in err
    assert not stamp.exists()  # neither the old digest nor the new one claims a good environment
    again = repro(project, "env")
    assert again.returncode == 0, again.stderr
    assert stamp.read_text().strip() == digest(project)


# ------------------------------------------------------- damaged .venv


def test_intact_env_starts_without_pip_and_passes_the_exit_code(project: Path):
    checked = repro(project, "env")
    assert checked.returncode == 0, checked.stderr
    assert "2 checked" in checked.stderr  # the marker-only package is not counted
    ran = repro(project, "run", "fig01", FAKE_EXIT="5")
    assert ran.returncode == 5
    assert [c["tool"] for c in calls(project)] == ["snakemake"]
    assert calls(project)[0]["args"] == ["--cores", "2", "fig01"]


def test_missing_file_is_reinstalled_from_the_lock(project: Path):
    core = project / SITE / "fakepkg" / "core.py"
    core.unlink()
    result = repro(project, "run")
    assert result.returncode == 0, result.stderr
    assert ".venv is damaged (fakepkg: fakepkg/core.py missing); reinstalling from environment.lock" in result.stderr
    forced = [c for c in calls(project) if "--force-reinstall" in c["args"]]
    assert len(forced) == 1
    assert forced[0]["requirements"] == "fakepkg==1.0 \\\n    --hash=sha256:aaaa \\\n    --hash=sha256:bbbb\n"
    assert core.read_text() == "restored"
    assert (project / ".venv" / ".scintrack-env-sha256").read_text().strip() == digest(project)
    assert calls(project)[-1]["tool"] == "snakemake"
    assert not list((project / ".venv").glob(".repair-*"))


def test_damage_a_reinstall_cannot_repair_is_one_error_line(project: Path):
    (project / ".venv" / "bin" / "fakecli").unlink()
    result = repro(project, "run", FAKE_PIP="broken")
    assert result.returncode == 2
    assert result.stderr.splitlines()[-1] == (
        "error: .venv is damaged (fakepkg: ../../../bin/fakecli missing) and reinstalling did not repair it; delete .venv and rerun"
    )
    assert [line for line in result.stderr.splitlines() if line.startswith("error:")] == [result.stderr.splitlines()[-1]]
    assert "Traceback" not in result.stderr
    assert "snakemake" not in [c["tool"] for c in calls(project)]
    assert not (project / ".venv" / ".scintrack-env-sha256").exists()


def test_venv_of_another_folder_is_refused(project: Path):
    (project / SITE / "__editable__.scintrack-0.1.0.pth").write_text("/elsewhere/proj/src\n")
    result = repro(project, "env")
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        f"error: .venv was installed for the project at /elsewhere/proj, not {project.resolve()} "
        "(a copied or moved folder); delete .venv and rerun"
    ]
    assert calls(project) == []


def test_check_reads_versions_names_and_records(project: Path):
    spec = importlib.util.spec_from_file_location("repro_copy", project / "repro.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    packages = module.locked_packages()
    assert sorted(packages) == ["fakepkg", "other-pkg"]
    assert module.damaged_packages(packages) == {}
    site = project / SITE
    (site / "other_pkg-2.0.dist-info").rename(site / "other_pkg-1.9.dist-info")
    (site / "fakepkg").rename(site / "gone")
    assert module.damaged_packages(packages) == {
        "fakepkg": "fakepkg/__init__.py missing",
        "other-pkg": "version 1.9 installed, the lock says 2.0",
    }
    shutil.rmtree(site / "scintrack-0.1.0.dist-info")
    assert module.damaged_packages(packages)["scintrack"] == "not installed"


# ------------------------------------------------------ path with a blank


def test_folder_with_a_blank_is_refused_before_anything_runs(tmp_path: Path):
    root = make_project(tmp_path / "my papers")
    stamp = (root / ".venv" / ".scintrack-env-sha256").read_text()
    result = repro(root, "run")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: the project folder {root.resolve()} has ' ' in its path")
    assert "Traceback" not in result.stderr
    assert calls(root) == []
    assert (root / ".venv" / ".scintrack-env-sha256").read_text() == stamp


@pytest.mark.skipif(importlib.util.find_spec("snakemake") is None, reason="needs Snakemake")
def test_snakefile_refuses_an_interpreter_with_a_blank(tmp_path: Path):
    # A venv in a folder with a blank whose site-packages path file points at
    # this environment's, so it runs the real Snakemake on the real Snakefile.
    venv = tmp_path / "my papers" / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    site = next(venv.glob("lib/python3*/site-packages"))
    (site / "outer.pth").write_text("\n".join(p for p in sys.path if p.endswith("site-packages")) + "\n")
    work = tmp_path / "work"
    work.mkdir()
    result = subprocess.run(
        [str(venv / "bin" / "python"), "-m", "snakemake", "-s", str(REPO / "Snakefile"), "-d", str(work), "-n"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode != 0
    assert result.stderr.strip().splitlines() == [
        f"error: the Python running Snakemake ({venv / 'bin' / 'python'}) has a blank or shell character in its path, "
        "so no job could start; move or clone the project (and its .venv) to a path without them and rerun"
    ]
