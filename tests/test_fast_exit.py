"""Workflow scripts end with the garbage collector frozen (scintrack.fast_exit; issue 14).

Checked in a child process through atexit's order (last registered, first
run): a handler registered *before* ``runlog.setup`` runs after the freeze
and sees every object in the permanent generation; an output written by the
script is complete; ``SCINTRACK_FULL_EXIT=1`` keeps the full collection.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

CHILD = """
import atexit, gc, sys
import numpy as np
atexit.register(lambda: print("frozen", gc.get_freeze_count(), flush=True))
from scintrack import runlog
from scintrack.atomic import atomic_bytes
runlog.setup(None, "case")
garbage = [[i] for i in range(100_000)]
for a in garbage:
    a.append(a)  # cycles: left to the final collection
atomic_bytes(sys.argv[1], np.arange(1000, dtype=np.float64).tobytes())
"""


def _run(tmp_path, **env):
    out = tmp_path / "out.bin"
    proc = subprocess.run([sys.executable, "-c", CHILD, str(out)], capture_output=True, text=True, timeout=120,
                          env={**os.environ, **env})
    assert proc.returncode == 0, proc.stderr[-2000:]
    counts = [int(line.split()[1]) for line in proc.stdout.splitlines() if line.startswith("frozen")]
    assert len(counts) == 1, proc.stdout
    return counts[0], np.frombuffer(out.read_bytes(), dtype=np.float64)


def test_a_script_ends_with_the_collector_frozen_and_its_output_complete(tmp_path):
    frozen, data = _run(tmp_path, SCINTRACK_FULL_EXIT="")
    assert frozen > 100_000  # the cycles and everything imported
    assert np.array_equal(data, np.arange(1000, dtype=np.float64))


def test_full_exit_setting_keeps_the_collection(tmp_path):
    frozen, data = _run(tmp_path, SCINTRACK_FULL_EXIT="1")
    assert frozen == 0
    assert np.array_equal(data, np.arange(1000, dtype=np.float64))
