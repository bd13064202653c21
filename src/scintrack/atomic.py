"""Atomic file writes: a temporary file beside the target, then ``os.replace``.

:func:`atomic_target` gives the temporary file the mode a plain ``open()``
would (``0666 & ~umask``): ``tempfile.mkstemp`` alone creates files with mode
0600, so outputs written atomically were unreadable to the group and others
(issue 15).  No heavy imports: the data registry uses it while Snakemake
builds the DAG.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path


def atomic_target(path: Path, suffix: str = ".part") -> tuple[int, str]:
    """(open descriptor, name) of a new temporary file beside ``path`` with a normal mode."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    return fd, tmp
