"""Interpreter start-up hook of a local run's script jobs: hand the job to the run's job server first.

:func:`scintrack.pipeline.job_server.start` puts this folder first on
``PYTHONPATH`` for the jobs of a run that has a job server.  Python imports
``sitecustomize`` while it starts, before the script, so a Snakemake script
job (``.snakemake/scripts/tmp*.py``) reaches
:func:`scintrack.pipeline.job_client.delegate` before Snakemake's preamble
imports snakemake (~60 of the job process's ~90 ms of CPU, on the path from
one job's end to the next one's start; ``docs/performance.md``, eleventh
round).  ``job_client`` is loaded from its file: importing the ``scintrack``
package would hash its sources (:mod:`scintrack.numba_cache`).

The job's ``threads`` come from ``OMP_NUM_THREADS``, which Snakemake sets to
them for every job; the server refuses a job whose thread-pool variables
differ from its own, as it does when the script's own first line calls
``delegate``, which stays the fallback (and a no-op in the fork).  Any other
``sitecustomize`` further along ``sys.path`` (the environment's, the user's)
runs first, as it would without this folder.  Nothing else happens here: any
other process, or any failure, continues its start-up unchanged.
"""

import os
import sys


def _chain() -> None:
    """Run the next ``sitecustomize`` on ``sys.path`` (this one shadows it)."""
    import importlib.machinery
    import importlib.util

    here = os.path.dirname(os.path.abspath(__file__))
    rest = [p for p in sys.path if os.path.abspath(p or os.curdir) != here]
    spec = importlib.machinery.PathFinder.find_spec("sitecustomize", rest)
    if spec is not None and spec.loader is not None:
        spec.loader.exec_module(importlib.util.module_from_spec(spec))


def _delegate_early() -> None:
    script = sys.argv[0] if sys.argv else ""
    if not os.environ.get("SCINTRACK_JOB_SERVER_ADDR") or not script.endswith(".py"):
        return
    if "/.snakemake/scripts/" not in os.path.abspath(script).replace(os.sep, "/"):
        return
    import importlib.util

    path = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "job_client.py")
    spec = importlib.util.spec_from_file_location("_scintrack_job_client_early", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.delegate(int(os.environ.get("OMP_NUM_THREADS") or 1))  # exits with the fork's status, or returns


try:
    _chain()
finally:
    try:
        _delegate_early()
    except Exception:  # noqa: BLE001, S110 - the script's own delegate() call, or its own process, takes over
        pass
