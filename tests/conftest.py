"""Shared fixtures: repository paths and one smoke run of the whole DAG per session.

The suite runs on two pytest-xdist workers (``-n 2 --dist loadgroup`` in
pyproject.toml; ``-n 0`` runs it in one process).  A session fixture runs once
*per worker*, so :func:`pytest_collection_modifyitems` puts every test that
needs :func:`smoke_run` in one xdist group (the smoke DAG is built once), keeps
the tests that share a module-scoped fixture on one worker (the fixture is
built once), and orders the items so that the long chains start first.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

#: whether numpy was loaded before this file (then its BLAS pool was sized already; ``tests/test_suite_threads.py``)
NUMPY_BEFORE_CONFTEST = "numpy" in sys.modules
#: linear-algebra thread variables as the suite found them (a value the user set is kept)
BLAS_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
USER_BLAS = {var: os.environ.get(var) for var in BLAS_VARIABLES}


def _one_blas_pool_per_core() -> None:
    """Size the linear-algebra thread pools of an xdist worker to its share of the cores.

    Each worker is one of ``PYTEST_XDIST_WORKER_COUNT`` processes that already fill the
    machine (two on two cores), and OpenBLAS otherwise starts a thread per core in each of
    them: the pools then oversubscribe the cores and their threads spin while they wait for
    work.
    Snakemake sets the same variables from ``threads`` for the jobs it runs, so the
    workflows the tests start are unaffected.  A value the user set is kept.
    """
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "0") or 0)
    if workers > 0:
        share = str(max(1, (os.cpu_count() or 1) // workers))
        for var in BLAS_VARIABLES:
            os.environ.setdefault(var, share)


_one_blas_pool_per_core()

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
#: the console script itself: for tests that need Snakemake as a process of its own (signals, resource limits)
SNAKEMAKE = str(BIN / "snakemake")
#: the environment every Snakemake the suite starts gets on top of the suite's own
SNAKEMAKE_ENV = {"PYTHONHASHSEED": "0"}
def snakemake_env(**extra: str) -> dict[str, str]:
    """The environment of a Snakemake the suite starts: the suite's own, :data:`SNAKEMAKE_ENV`, then ``extra``."""
    return dict(os.environ, **SNAKEMAKE_ENV, **extra)


def registry_text(datasets: dict) -> str:
    """A dataset registry of a test's own: the repository's entries (real recordings, indices, ephemerides) with
    ``datasets`` added or replacing theirs, so the rules that read other entries still find them."""
    import yaml

    base = yaml.safe_load((REPO / "data" / "registry.yaml").read_text(encoding="utf-8"))
    return yaml.safe_dump({**base, "datasets": {**base["datasets"], **datasets}}, sort_keys=False)


def snakemake_cmd() -> list[str]:
    """The command that runs ``snakemake``, as a user runs it (arguments are appended)."""
    return [SNAKEMAKE]


def run_snakemake(workdir: Path, *args: str, timeout: float = 900, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    """Run the repository's Snakefile with the smoke overlay in ``workdir`` (``env``: variables added to the environment)."""
    cmd = [
        *snakemake_cmd(), "-s", str(REPO / "Snakefile"), "--directory", str(workdir),
        "--configfile", str(REPO / "config" / "smoke.yaml"), "--cores", "2", *args,
    ]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=snakemake_env(**(env or {})))


@pytest.fixture(scope="session")
def smoke_run(tmp_path_factory) -> Path:
    """The smoke DAG built once in a fresh folder; returns that folder."""
    workdir = tmp_path_factory.mktemp("smoke")
    proc = run_snakemake(workdir, "-q")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return workdir


def cores_per_worker() -> int:
    """The cores a test may fill with processes of its own: this worker's share (one of two under
    ``-n 2`` on the 2-core machine) while the smoke chain, the suite's longest, is selected in this
    session and keeps another worker busy to the end; else every core (without xdist, or a
    selection such as ``-k csm`` that leaves the other worker idle after a few seconds)."""
    cores = os.cpu_count() or 1
    if not _SESSION.get("smoke_selected"):
        return cores
    return max(1, cores // int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")))


def experiment_jobs(experiments: dict) -> dict[str, int]:
    """Jobs that a set of experiment specs (name -> spec) plans: one ``tracking_<name>`` job per experiment."""
    return {f"tracking_{name}": 1 for name in experiments}


def run_targets(workdir: Path, *targets: str, overlays=(), timeout: float = 600) -> subprocess.CompletedProcess:
    """Build ``targets`` (rule names or files; before --configfile, which takes every following word)."""
    cmd = [*snakemake_cmd(), *targets, "-s", str(REPO / "Snakefile"), "--directory", str(workdir), "--cores", "2",
           "--configfile", str(REPO / "config" / "smoke.yaml"), *map(str, overlays)]
    env = snakemake_env()
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)


#: facts about this session's selection (set by :func:`pytest_collection_finish`)
_SESSION: dict[str, bool] = {}
#: xdist group of the tests that use :func:`smoke_run` (directly or through another fixture, e.g. the
#: cluster build or the one-core build): all on one worker, so the smoke DAG (~150 s) is built once.
SMOKE_GROUP = "smoke"
#: fixture scopes that xdist would build once per worker that runs a test of theirs
_SHARED_SCOPES = ("module", "class", "package")


def _shares_a_fixture(item: pytest.Item) -> bool:
    """Whether a module-, class- or package-scoped fixture serves ``item`` (pytest's fixture info)."""
    info = getattr(item, "_fixtureinfo", None)
    defs = getattr(info, "name2fixturedefs", {}) or {}
    return any(getattr(d, "scope", "function") in _SHARED_SCOPES for chain in defs.values() for d in chain)


def xdist_group(item: pytest.Item) -> str | None:
    """The xdist group of ``item``: the smoke group, its module's name when it shares a module-scoped
    fixture (the bad-input catalogue's 47 cases share one 75-s fixture), else none (any worker)."""
    if "smoke_run" in item.fixturenames:
        return SMOKE_GROUP
    if _shares_a_fixture(item):
        return item.path.stem  # test modules have unique names (they import as top-level modules)
    return None


def _append_group_to_node_id(item: pytest.Item, group: str) -> None:
    """Give ``item`` the node id ``<id>@<group>``, which ``--dist loadgroup`` schedules by.

    pytest-xdist 3.8 appends the suffix by assigning ``item._nodeid``; pytest 9.2 builds node ids from
    a structured ``item._id`` and ignores ``_nodeid``, so the groups were silently lost and every
    worker built its own smoke DAG (pytest-xdist issue 1386, fix not released).  Where ``_id``
    exists the suffix is set here; xdist's own assignment then changes nothing (and on a release that
    does it itself, the id ends ``@smoke@smoke``, which xdist still reads as group ``smoke``).
    """
    node_id = getattr(item, "_id", None)
    if node_id is not None and hasattr(type(node_id), "parse") and not item.nodeid.endswith(f"@{group}"):
        item._id = type(node_id).parse(f"{item.nodeid}@{group}")


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook (pytest_collection_modifyitems of its worker)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Group the items for ``--dist loadgroup`` (:func:`xdist_group`) and start the long chains first.

    With ``--no-loadscope-reorder`` xdist hands out work units in collection order, so the items are
    reordered, stably: the smoke group first (the longest chain: smoke DAG, cluster build, one-core
    build, archive; one worker), then the other ``pipeline`` tests (bad-input catalogue,
    kill-and-resume, ...: the other worker), then the unit tests, which fill both workers to the end.
    The order within each of the three parts is the collection order, so the smoke tests keep
    their relative order.  Without xdist (``-n 0``) the marks are inert and only the order changes.
    """
    groups = {item: xdist_group(item) for item in items}
    loadgroup = getattr(config.option, "loadgroup", False)  # set in xdist's workers only
    for item, group in groups.items():
        if group is not None:
            item.add_marker(pytest.mark.xdist_group(group))
            if loadgroup:
                _append_group_to_node_id(item, group)

    def rank(item: pytest.Item) -> int:
        if groups[item] == SMOKE_GROUP:
            return 0
        return 1 if item.get_closest_marker("pipeline") else 2

    items.sort(key=rank)  # list.sort is stable


def pytest_collection_finish(session: pytest.Session) -> None:
    """Record whether the smoke group is selected (after ``-k``/``-m``), for :func:`cores_per_worker`."""
    _SESSION["smoke_selected"] = any("smoke_run" in item.fixturenames for item in session.items)
