"""Cheaper samples for Snakemake's ``benchmark:`` directive (CPU of the Snakemake process itself).

Snakemake times every job that has a ``benchmark:`` file with a thread of its
own process: every 0.5 s for the first ~15 s of a job and every 30 s after,
it walks the job's process tree with psutil and reads, for each process,
``memory_full_info()``, i.e. ``/proc/PID/smaps_rollup``, for which the
kernel walks the page tables of the whole process to give USS and PSS.  On
the project's 2-core machine that sampling competes with the jobs for the
same two cores: in a full run the Snakemake process used 175 CPU-s (91 user
+ 84 system; the larger part was its scheduler's one-second timer, see
``profiles/default/config.yaml``), and py-spy on it while it ran 19
cycle-slip shard jobs put 74% of its busy samples in the benchmark
sampling, 70% of those in ``memory_full_info``; the light sampler took its
system time there from 4.7 to 0.9 s (``docs/performance.md``, seventh round).

:func:`install` replaces the sampler's record update by one that reads
``memory_info()`` instead (``/proc/PID/statm``: RSS and VMS, about 50 times
cheaper for a 1-GB numpy process) and leaves ``max_uss`` / ``max_pss`` unset
(``-`` in the TSV).  Everything else is Snakemake's: when it samples, the
columns, ``max_rss``, ``max_vms``, ``io_in``/``io_out``, ``mean_load`` and
``cpu_time`` are computed as in Snakemake 9.27.  The project reads only
``s`` and ``max_rss`` (:mod:`.resources`, the archive's run metadata).

A job that runs in a fork of the job server (:mod:`.job_server`) is sampled
with that fork (:func:`follow_forks`): the fork is the server's child, not the
job process's, so the process tree alone would miss it.

It changes the Snakemake process only (the Snakefile calls :func:`install`
while it is parsed, which every Snakemake process does, also a cluster job's),
never a job's results.  If the pinned Snakemake ever lacks the class this
replaces, :func:`install` leaves Snakemake's own sampler in place.
"""

from __future__ import annotations

import time

MB = 1024 * 1024
#: The job server's folder of ``<job pid>`` files holding the pid of the fork that runs that job
#: (:mod:`.job_server`), or None: such a fork is sampled as part of the job's process tree.
_FORKS_DIR = None


def follow_forks(folder) -> None:
    """Count the job server's fork of a job with that job (``folder``: the server's pid files; None: stop)."""
    global _FORKS_DIR
    _FORKS_DIR = folder


def _with_forks(procs: list) -> list:
    """``procs`` plus, for each job process the job server runs in a fork, that fork."""
    import psutil

    if _FORKS_DIR is None:
        return procs
    extra = []
    for proc in procs:
        try:
            child = int((_FORKS_DIR / str(proc.pid)).read_text())
        except (OSError, ValueError):
            continue
        try:
            extra.append(psutil.Process(child))
        except psutil.Error:
            continue
    return procs + extra


def _update_record(self) -> None:
    """One sample of the observed process tree into ``self.bench_record`` (RSS/VMS from statm)."""
    import psutil

    record = self.bench_record
    now = time.time()
    try:
        procs = _with_forks([self.main, *self.main.children(recursive=True)])
    except psutil.NoSuchProcess:  # the job ended before this sample
        record.process_gone = True
        return
    except (OSError, psutil.Error) as exc:
        record.errors.append(str(exc))
        return
    rss = vms = io_in = io_out = 0
    check_io = True
    cpu_usage = 0.0
    collected = False
    for proc in procs:
        proc = self.procs.setdefault(proc.pid, proc)  # cpu_percent() needs the same object each time
        try:
            with proc.oneshot():
                if record.prev_time:
                    cpu_usage += proc.cpu_percent() * (now - record.prev_time)
                try:
                    mem = proc.memory_info()
                except psutil.NoSuchProcess:
                    raise
                except psutil.Error:
                    try:
                        name = proc.name()
                    except psutil.Error:
                        name = "?"
                    record.skipped_procs.add((proc.pid, name))
                    continue
                rss += mem.rss
                vms += mem.vms
                if check_io:
                    try:
                        io = proc.io_counters()
                        io_in += io.read_bytes
                        io_out += io.write_bytes
                    except (NotImplementedError, AttributeError):
                        check_io = False
                times = proc.cpu_times()
                record.processed_procs[(proc.pid, proc.name())] = times.user + times.system
        except psutil.NoSuchProcess:
            if proc.pid == self.main.pid:
                record.process_gone = True
            continue
        except (OSError, psutil.Error) as exc:
            record.errors.append(str(exc))
            continue
        collected = True
    if not collected:
        return
    record.prev_time = now
    record.data_collected = True
    record.max_rss = max(record.max_rss or 0, rss / MB)
    record.max_vms = max(record.max_vms or 0, vms / MB)
    record.io_in = io_in / MB if check_io else None
    record.io_out = io_out / MB if check_io else None
    record.cpu_usage += cpu_usage
    record.cpu_time = sum(record.processed_procs.values())


def install() -> bool:
    """Make Snakemake's benchmark sampler read RSS/VMS only; True if installed (see the module docstring)."""
    try:
        from snakemake import benchmark
    except ImportError:
        return False
    timer = getattr(benchmark, "BenchmarkTimer", None)
    if timer is None or not hasattr(timer, "_update_record"):
        return False
    timer._update_record = _update_record
    return True
