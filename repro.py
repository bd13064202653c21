#!/usr/bin/env python3
"""One entry point for researchers: set up the locked environment, then run.

    python3 repro.py run [SNAKEMAKE ARGS]   full reproduction (snakemake --cores 2)
    python3 repro.py test [PYTEST ARGS]     the test suite
    python3 repro.py env                    only create/refresh the environment

Needs only CPython >= 3.11 with pip, so it imports nothing from the project.

* **Environment.** ``.venv`` beside this file, installed from
  ``environment.lock`` with ``--require-hashes`` plus the project itself
  (editable).  A stamp (the sha256 of the lock and ``pyproject.toml``) marks
  it ready; it is written, atomically, only after every install step
  succeeded, and removed before any install step starts, so an interrupted
  or failed install is never taken for a ready one.
* **Damage.** Even when the stamp matches, every start checks that each
  locked package is installed at its locked version with every file its
  ``RECORD`` lists (compiled ``__pycache__`` files aside), and that the
  editable install points at this folder (tens of milliseconds, a stat per
  file).  Damaged packages are reinstalled from the lock (hash-checked,
  forced); what that cannot repair (a ``.venv`` copied or moved from another
  folder, a reinstall that did not help) stops with one ``error:`` line
  saying to delete ``.venv`` and rerun.
* **Ctrl-C.** The terminal sends SIGINT to the whole foreground process
  group, so Snakemake, pytest or pip gets it directly and stops in its own
  way (Snakemake removes its lock and incomplete outputs).  This script only
  waits for the child and exits with its exit code (128 + N when a signal N
  ended it), without a traceback.  It does not forward the signal: the
  child already has it from the terminal, and forwarding would deliver it
  twice.  A further Ctrl-C prints one line and keeps waiting.  A Ctrl-C
  during the install leaves the environment unstamped: the next start
  completes it.  Creating ``.venv`` itself (a few seconds) runs out of the
  terminal's reach; a Ctrl-C then waits for it and removes the new folder.
* **Paths.** Snakemake starts each job's script as ``<python> <script>``
  through bash without quoting the interpreter's path, so a project folder
  whose path contains a blank or a shell character cannot run a job; it is
  refused up front (the Snakefile refuses such an interpreter too).
"""

from __future__ import annotations

import csv
import hashlib
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import NoReturn

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
STAMP = VENV / ".scintrack-env-sha256"
BIN = VENV / "bin"
LOCK = ROOT / "environment.lock"
PIP = ["-m", "pip", "install", "--disable-pip-version-check", "--no-deps"]
# Characters that bash splits or expands in an unquoted word.
SHELL_SPECIAL = frozenset(" \t\n'\"\\$`;&|<>()*?[")


class Refusal(Exception):
    """A problem the user fixes: one line naming the file or folder and the fix."""


def fail(message: str) -> NoReturn:
    raise Refusal(message)


def say(message: str) -> None:
    print(f"repro.py: {message}", file=sys.stderr, flush=True)


# ---------------------------------------------------------------- children


def exit_status(returncode: int) -> int:
    """A child's exit status as a shell reports it (128 + N for death by signal N)."""
    return 128 - returncode if returncode < 0 else returncode


def run_child(cmd: list[str], env: dict[str, str] | None = None, shielded: bool = False) -> tuple[int, int]:
    """Run ``cmd`` to its end; return (exit status, number of Ctrl-C seen meanwhile).

    SIGINT is caught (not ignored: an ignored signal would stay ignored in
    the child) and only counted, so the child, which gets the same SIGINT
    from the terminal, finishes its own shutdown.  ``shielded``: the child
    runs in a session of its own, out of the terminal's reach, and always
    finishes (for a short step that prints a traceback when interrupted).
    """
    name = Path(cmd[0]).name if cmd[1:2] != ["-m"] else cmd[2]
    seen = 0

    def on_sigint(signum, frame):
        nonlocal seen
        seen += 1
        if seen == 2:
            say(f"waiting for {name} to finish stopping (it got the Ctrl-C too; cutting it short would leave its lock and temporary files)")

    previous = signal.signal(signal.SIGINT, on_sigint)
    try:
        try:
            proc = subprocess.Popen(cmd, cwd=ROOT, env=env, start_new_session=shielded)
        except OSError as exc:
            fail(f"cannot start {cmd[0]} ({exc.strerror}); delete .venv and rerun")
        returncode = proc.wait()
    finally:
        signal.signal(signal.SIGINT, previous)
    return exit_status(returncode), seen


def install_step(cmd: list[str], shielded: bool = False) -> None:
    """One environment install step; stop (without stamping) on failure or Ctrl-C."""
    print("+", " ".join(cmd), flush=True)
    status, interrupted = run_child(cmd, shielded=shielded)
    if interrupted:
        say("environment install interrupted; .venv is not marked ready and the next start completes it")
        raise SystemExit(status or 130)
    if status != 0:
        step = cmd[2] if cmd[1:2] == ["-m"] else Path(cmd[0]).name
        fail(
            f"installing .venv failed ({step} exit code {status}, its reason is above); fix that (network, disk space) and rerun, or delete .venv and rerun"
        )


# ------------------------------------------------------- environment state


def env_digest() -> str:
    h = hashlib.sha256()
    for name in ("environment.lock", "pyproject.toml"):
        h.update((ROOT / name).read_bytes())
    return h.hexdigest()


def write_stamp(digest: str) -> None:
    tmp = STAMP.with_name(f"{STAMP.name}.{os.getpid()}.tmp")
    tmp.write_text(digest + "\n")
    os.replace(tmp, STAMP)


def canonical(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def locked_packages() -> dict[str, tuple[str, str]]:
    """{canonical name: (version, its requirement lines with hashes)} of environment.lock.

    A requirement with an environment marker is left out: this script cannot
    evaluate the marker, and such a package may rightly be absent.
    """
    packages, current = {}, None
    for line in LOCK.read_text().splitlines():
        match = re.match(r"([A-Za-z0-9][A-Za-z0-9._-]*)==([^\s;\\]+)\s*(;)?", line)
        if match:
            current = None if match.group(3) else canonical(match.group(1))
            if current:
                packages[current] = (match.group(2), line)
        elif current and line[:1].isspace() and line.strip().startswith("--hash"):
            version, text = packages[current]
            packages[current] = (version, f"{text}\n{line}")
        else:
            current = None
    return packages


def site_packages() -> list[Path]:
    return sorted(VENV.glob("lib/python3*/site-packages"))


def installed() -> dict[str, list[tuple[str, Path]]]:
    """{canonical name: [(version, its .dist-info folder)]} of what .venv holds."""
    found: dict[str, list[tuple[str, Path]]] = {}
    for site in site_packages():
        for info in site.glob("*.dist-info"):
            name, _, version = info.name[: -len(".dist-info")].rpartition("-")
            found.setdefault(canonical(name), []).append((version, info))
    return found


def record_files(info: Path) -> list[str] | None:
    """The files the RECORD of ``info`` lists (relative to site-packages), bytecode aside; None without a RECORD."""
    try:
        with open(info / "RECORD", newline="") as fh:
            rows = list(csv.reader(fh))
    except OSError:
        return None
    return [row[0] for row in rows if row and row[0] and "__pycache__/" not in row[0] and not row[0].endswith(".pyc")]


def damage(info: Path) -> str | None:
    """The first file of an installed distribution that is missing, as 'FILE missing'."""
    files = record_files(info)
    if files is None:
        return f"{info.name}/RECORD missing"
    base = f"{info.parent}{os.sep}"
    for rel in files:
        if not os.path.exists(base + rel):
            return f"{rel} missing"
    return None


def damaged_packages(packages: dict[str, tuple[str, str]]) -> dict[str, str]:
    """{canonical name: what is wrong} for every locked package, and for scintrack itself."""
    found = installed()
    problems = {}
    for name, (version, _) in packages.items():
        versions = [v for v, _ in found.get(name, [])]
        infos = [info for v, info in found.get(name, []) if v == version]
        if not versions:
            problems[name] = "not installed"
        elif not infos:
            problems[name] = f"version {', '.join(versions)} installed, the lock says {version}"
        else:
            problem = damage(infos[0])
            if problem:
                problems[name] = problem
    own = found.get("scintrack", [])
    if not own:
        problems["scintrack"] = "not installed"
    else:
        problem = damage(own[0][1])
        if problem:
            problems["scintrack"] = problem
    return problems


def moved_from() -> str | None:
    """The folder the editable install of scintrack points at, when that is not this one."""
    src = str(ROOT / "src")
    for site in site_packages():
        for editable in site.glob("__editable__*scintrack*"):
            try:
                text = editable.read_text(errors="replace")
            except OSError:
                continue
            if src in text:
                return None
            for line in text.splitlines():
                if line.strip().startswith("/"):
                    return str(Path(line.strip()).parent) if line.strip().endswith("/src") else line.strip()
            return f"another folder (see {editable})"
    return None


def describe(problems: dict[str, str]) -> str:
    name, problem = next(iter(problems.items()))
    more = f"; {len(problems) - 1} more package(s) damaged" if len(problems) > 1 else ""
    return f"{name}: {problem}{more}"


# ------------------------------------------------------------ environment


def check_path() -> None:
    special = sorted(set(str(VENV)) & SHELL_SPECIAL)
    if special:
        shown = " ".join(repr(c) for c in special)
        fail(
            f"the project folder {ROOT} has {shown} in its path, and Snakemake starts every job as "
            "'<.venv/bin/python> <script>' through bash without quoting the interpreter, so no job could start; "
            "move or clone the project to a path without blanks or shell characters and rerun"
        )


def ensure_env(verbose: bool = False) -> None:
    if sys.version_info < (3, 11):  # noqa: UP036 (runs under any python3 before the venv exists)
        fail(f"Python >= 3.11 is required (this is {sys.version.split()[0]}); run repro.py with python3.11")
    check_path()
    python = BIN / "python"
    if python.exists():
        elsewhere = moved_from()
        if elsewhere:
            fail(f".venv was installed for the project at {elsewhere}, not {ROOT} (a copied or moved folder); delete .venv and rerun")
    digest = env_digest()
    packages = locked_packages()
    if python.exists() and STAMP.exists() and STAMP.read_text().strip() == digest:
        problems = damaged_packages(packages)
        if not problems:
            if verbose:
                say(f".venv holds every package of environment.lock ({len(packages)} checked) and scintrack")
            return
        say(f".venv is damaged ({describe(problems)}); reinstalling from environment.lock")
    STAMP.unlink(missing_ok=True)
    if not VENV.exists():  # a few seconds; Ctrl-C waits for it, then removes what it made
        try:
            install_step([sys.executable, "-m", "venv", str(VENV)], shielded=True)
        except BaseException:
            shutil.rmtree(VENV, ignore_errors=True)
            raise
    elif not python.exists():
        install_step([sys.executable, "-m", "venv", str(VENV)], shielded=True)
    install_step([str(python), *PIP, "--require-hashes", "-r", "environment.lock"])
    broken = {name: problem for name, problem in damaged_packages(packages).items() if name in packages}
    if broken:  # pip takes a package whose metadata is intact for installed, whatever files are missing
        fd, name = tempfile.mkstemp(prefix=".repair-", suffix=".txt", dir=VENV)
        try:
            with os.fdopen(fd, "w") as fh:
                fh.write("".join(packages[p][1] + "\n" for p in broken))
            install_step([str(python), *PIP, "--require-hashes", "--force-reinstall", "-r", name])
        finally:
            Path(name).unlink(missing_ok=True)
    install_step([str(python), *PIP, "--no-build-isolation", "-e", "."])
    problems = damaged_packages(packages)
    if problems:
        fail(f".venv is damaged ({describe(problems)}) and reinstalling did not repair it; delete .venv and rerun")
    write_stamp(digest)


# ------------------------------------------------------------------ main


def config_files(args: list[str]) -> list[str]:
    """The files given to Snakemake's --configfile/--configfiles (every word after it, as Snakemake reads them)."""
    files, taking = [], False
    for arg in args:
        if arg in ("--configfile", "--configfiles"):
            taking = True
        elif arg.startswith("--configfile=") or arg.startswith("--configfiles="):
            files.append(arg.split("=", 1)[1])
            taking = True
        elif arg.startswith("-"):
            taking = False
        elif taking:
            files.append(arg)
    return files


def main(argv: list[str]) -> int:
    if not argv or argv[0] not in {"run", "test", "env"}:
        print(__doc__.split("\n* ", 1)[0].rstrip(), file=sys.stderr)  # the usage, not the notes
        return 2
    command, rest = argv[0], argv[1:]
    ensure_env(verbose=command == "env")
    env = dict(os.environ, PATH=f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}", MPLBACKEND="Agg")
    if command == "env":
        return 0
    if command == "run":
        files = config_files(rest)
        if files:  # Snakemake's own YAML error does not name the file
            status, _ = run_child([str(BIN / "python"), "-m", "scintrack", "check-config", *files], env=env)
            if status != 0:
                return status
        cmd = [str(BIN / "snakemake"), "--cores", "2", *rest]
    else:
        cmd = [str(BIN / "python"), "-m", "pytest", *rest]
    print("+", " ".join(cmd), flush=True)
    return run_child(cmd, env=env)[0]


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except Refusal as exc:
        print(f"error: {' '.join(str(exc).split())}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:  # Ctrl-C while no child runs: nothing half-done to report
        print(file=sys.stderr)
        sys.exit(130)
