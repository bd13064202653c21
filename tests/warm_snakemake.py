"""Run one ``snakemake`` command in a fork of the suite's warm Snakemake server, or else as itself.

    python tests/warm_snakemake.py ADDRESS SNAKEMAKE [snakemake arguments...]

The test suite starts Snakemake about sixty times, and each start-up spends
about a second importing Snakemake, its plugins and what they import (pandas,
jsonschema, ...) before it reads the Snakefile (issue 14, test-suite time).
:func:`conftest.snakemake_cmd` starts one server per test process
(:mod:`scintrack.pipeline.job_server`, the same fork server the workflow's
jobs use) that has imported them once, and returns this script as the command.
Here the command line, working directory, environment and standard streams
go to the server; a fork of it runs ``SNAKEMAKE`` (the console script) as
``python SNAKEMAKE ...`` would, with ``scintrack`` imported afresh from the
Snakefile's own ``src`` (``--forget scintrack``), and this process exits as
the fork did.  If the server cannot serve it (no server, another interpreter,
other import-time environment variables), this process becomes the plain
``SNAKEMAKE`` command (``exec``), so the result never depends on the server.

Only the standard library is used before the hand-over: the job client is
loaded from its file, without the package (whose import would set
``NUMBA_CACHE_DIR`` in the environment handed over).
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

CLIENT = Path(__file__).resolve().parents[1] / "src" / "scintrack" / "pipeline" / "job_client.py"


def main() -> None:
    addr, snakemake, *args = sys.argv[1:]
    sys.argv = [snakemake, *args]
    if addr:
        spec = importlib.util.spec_from_file_location("warm_snakemake_job_client", CLIENT)
        client = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(client)
        client.delegate(1, addr=addr)  # returns only if no fork ran the command
    os.execv(snakemake, sys.argv)


if __name__ == "__main__":
    main()
