"""Workflow jobs end without the interpreter's last full garbage collection.

When a Python process ends, CPython (3.11) tears the interpreter down and
runs full passes of the cyclic garbage collector on the way.  A job process
has imported numpy, scipy, xarray, pandas and numba (with llvmlite's type
objects), and those passes traverse every one of its millions of live
objects, only for the operating system to take the whole memory back a
moment later.  py-spy on a small tracking job put 41% of its samples after
the script's last line, almost all in ``gc_collect_main``; ending the same job
with the collector frozen took 2.15-2.63 -> 1.52-2.04 user CPU-s and
3.3-4.6 -> 2.5-3.9 s of wall time (three interleaved runs; ending it with
``os._exit`` saved the same; docs/performance.md, seventh round), about half
a CPU-second for each of the ~270 jobs of a full run.

:func:`install` (called by :func:`scintrack.runlog.setup`, i.e. by every
workflow script) registers :func:`gc.freeze` with :mod:`atexit`.  atexit
handlers run at the start of the shutdown, before the interpreter's teardown,
so every object is in the collector's permanent generation by the time the
final passes run, and they have nothing to traverse.

What this skips, and why it is safe here: only the collection of garbage
that is part of reference cycles.  Objects freed by reference counting during
the teardown are freed as before (their ``__del__`` runs); atexit handlers,
logging's flush and close among them (registered when :mod:`logging` is
imported, so run after this one), run as before.  Every output of a job is
written and closed, then renamed into place, before the script returns
(:mod:`scintrack.atomic`), so no result waits for a collector to close it.

``SCINTRACK_FULL_EXIT=1`` in the environment keeps the full collection (for
debugging a finaliser that must run at exit).
"""

from __future__ import annotations

import atexit
import gc
import os

ENV = "SCINTRACK_FULL_EXIT"
_installed = False


def install() -> bool:
    """Freeze the garbage collector at exit (once per process); False if ``$SCINTRACK_FULL_EXIT`` asks not to."""
    global _installed
    if os.environ.get(ENV, "") not in ("", "0"):
        return False
    if not _installed:
        atexit.register(gc.freeze)
        _installed = True
    return True
