#!/usr/bin/env python3
"""One entry point for researchers: set up the locked environment, then run.

    python3 repro.py run [SNAKEMAKE ARGS]   full reproduction (snakemake --cores 2)
    python3 repro.py test [PYTEST ARGS]     the test suite
    python3 repro.py env                    only create/refresh the environment

Needs only CPython >= 3.11 with pip.  The environment is ``.venv`` beside this
file, installed from ``environment.lock`` with ``--require-hashes``; it is
refreshed whenever the lock file or ``pyproject.toml`` changes.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
STAMP = VENV / ".scintrack-env-sha256"
BIN = VENV / "bin"


def fail(message: str) -> None:
    print(f"repro.py: {message}", file=sys.stderr)
    raise SystemExit(2)


def env_digest() -> str:
    h = hashlib.sha256()
    for name in ("environment.lock", "pyproject.toml"):
        h.update((ROOT / name).read_bytes())
    return h.hexdigest()


def run(cmd: list[str], **kwargs) -> None:
    print("+", " ".join(cmd), flush=True)
    proc = subprocess.run(cmd, cwd=ROOT, **kwargs)
    if proc.returncode != 0:
        fail(f"command failed with exit code {proc.returncode}: {' '.join(cmd)}")


def ensure_env() -> None:
    if sys.version_info < (3, 11):  # noqa: UP036 (runs under any python3 before the venv exists)
        fail(f"Python >= 3.11 is required (this is {sys.version.split()[0]}); run repro.py with python3.11")
    digest = env_digest()
    python = BIN / "python"
    if python.exists() and STAMP.exists() and STAMP.read_text().strip() == digest:
        return
    if not python.exists():
        run([sys.executable, "-m", "venv", str(VENV)])
    run([str(python), "-m", "pip", "install", "--disable-pip-version-check", "--require-hashes", "--no-deps", "-r", "environment.lock"])
    run([str(python), "-m", "pip", "install", "--disable-pip-version-check", "--no-deps", "--no-build-isolation", "-e", "."])
    STAMP.write_text(digest + "\n")


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
        print(__doc__, file=sys.stderr)
        return 2
    ensure_env()
    command, rest = argv[0], argv[1:]
    env = dict(os.environ, PATH=f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}", MPLBACKEND="Agg")
    if command == "env":
        return 0
    if command == "run":
        files = config_files(rest)
        if files:  # Snakemake's own YAML error does not name the file
            check = subprocess.run([str(BIN / "python"), "-m", "scintrack", "check-config", *files], cwd=ROOT, env=env)
            if check.returncode != 0:
                return check.returncode
        cmd = [str(BIN / "snakemake"), "--cores", "2", *rest]
    else:
        cmd = [str(BIN / "python"), "-m", "pytest", *rest]
    print("+", " ".join(cmd), flush=True)
    return subprocess.run(cmd, cwd=ROOT, env=env).returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
