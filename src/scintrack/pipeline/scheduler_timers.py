"""End a Snakemake run without waiting for its scheduler's last re-evaluation timer.

With a job-rate limit (``--max-jobs-per-timespan``, set to ``100/10s`` by
``profiles/default/config.yaml``), every pass of Snakemake's scheduler arms a
``threading.Timer`` of one timespan that wakes the scheduler again.  The
timers are ordinary (non-daemon) threads, so when the workflow is done the
interpreter waits for the last one before the process exits: up to one
timespan after "Elapsed time" (measured: a one-job run 12.8 s with the
10-s timespan, 3.6 s without; docs/performance.md, seventh round).

:func:`cancel_pending` cancels every pending ``threading.Timer`` of the
process; the Snakefile calls it from ``onsuccess`` and ``onerror``, i.e.
after the scheduler has returned, when nothing listens to those timers any
more.  (Snakemake's benchmark sampler uses its own thread class, not
``threading.Timer``, and has stopped by then.)
"""

from __future__ import annotations

import threading


def cancel_pending() -> int:
    """Cancel every pending ``threading.Timer`` of this process; returns how many were cancelled."""
    timers = [t for t in threading.enumerate() if isinstance(t, threading.Timer) and t.is_alive()]
    for timer in timers:
        timer.cancel()
    return len(timers)
