"""Opt-in whole-run profiling of the workflow scripts: where the CPU time of a run goes.

With the environment variable ``SCINTRACK_PROFILE=<dir>`` set, every script
job profiles itself with :mod:`cProfile` from the moment it sets up its log
(:func:`scintrack.runlog.setup` calls :func:`start`) and, at exit, writes
``<dir>/<rule>/<name>-<pid>.prof`` (``rule``: the Snakemake rule of the job) (pstats) and a ``.json`` beside it with

* ``startup_s``: CPU seconds from process creation to :func:`start`
  (interpreter start, Snakemake's script preamble, the imports of
  numpy/xarray/numba/...),
* ``profiled_s``: CPU seconds from :func:`start` to exit (what the ``.prof``
  covers), and ``wall_s``, the wall seconds of the same span.

The profiler's timer is the process CPU time (``time.process_time``), so
the breakdown is in CPU seconds and does not depend on how loaded the
machine was (a job waiting for a core costs nothing).

Without the variable nothing happens (no overhead, results unchanged: the
profiler only observes).  ``benchmarks/profile_breakdown.py`` turns a folder
of these into the per-rule breakdown of ``docs/performance.md``.
"""

from __future__ import annotations

import atexit
import json
import os
import sys
import time
from pathlib import Path

ENV = "SCINTRACK_PROFILE"


def _cpu_so_far() -> float:
    """CPU seconds (user + system) this process has used (psutil, a Snakemake dependency)."""
    import psutil

    t = psutil.Process(os.getpid()).cpu_times()
    return float(t.user + t.system)


def start(name: str) -> bool:
    """Profile the rest of this process if ``$SCINTRACK_PROFILE`` is set; returns whether it is."""
    root = os.environ.get(ENV)
    if not root:
        return False
    import cProfile

    t0, c0 = time.time(), time.process_time()
    startup = _cpu_so_far()
    job = getattr(sys.modules.get("__main__"), "snakemake", None)  # the script's Snakemake object, if any
    rule = str(getattr(job, "rule", "") or name.split("/")[0])
    out = Path(root) / rule
    out.mkdir(parents=True, exist_ok=True)
    stem = out / f"{name.replace('/', '_')}-{os.getpid()}"
    prof = cProfile.Profile(time.process_time)

    def _dump() -> None:
        prof.disable()
        prof.dump_stats(str(stem) + ".prof")
        Path(str(stem) + ".json").write_text(json.dumps({"rule": rule, "name": name, "startup_s": startup, "profiled_s": time.process_time() - c0,
                                                       "wall_s": time.time() - t0}))

    atexit.register(_dump)
    prof.enable()
    return True


# --- the breakdown ---------------------------------------------------------------------------

#: categories of the breakdown, by the file a function is defined in (first match wins);
#: time of functions in no category (numpy, scipy, builtins) goes to their callers' categories.
CATEGORIES = (
    ("imports inside the job", ("<frozen importlib", "/importlib/")),
    ("numba compilation / cache load", ("/numba/", "/llvmlite/")),
    ("filtering (trackers, DLL)", ("/scintrack/trackers/", "/scintrack/navigation/dll")),
    ("signal generation", ("/scintrack/signals/", "/scintrack/experiments/scenario", "/scintrack/data/", "/scintrack/experiments/traces")),
    ("AR fitting / models", ("/scintrack/models/", "/statsmodels/")),
    ("floors (linear algebra)", ("/scintrack/experiments/floors",)),
    ("metrics and estimators", ("/scintrack/experiments/", "/scintrack/estimators/", "/scintrack/navigation/")),
    ("I/O (NetCDF, YAML, hashes)", ("/xarray/backends/", "/netCDF4", "/h5netcdf/", "/h5py/", "/scintrack/io", "/yaml/", "/hashlib", "/scintrack/checksums",
                                    "/scintrack/archive/", "/tarfile", "/gzip")),
    ("figures and tables", ("/matplotlib/", "/scintrack/figures/", "/scintrack/tables/", "/PIL/")),
)


def _category(filename: str) -> str | None:
    for cat, keys in CATEGORIES:
        if any(k in filename for k in keys):
            return cat
    return None


def _shares(stats: dict, func, memo: dict, active: set) -> dict[str, float]:
    """Fractions per category that ``func``'s own time goes to: its own category, or its callers' shares
    weighted by the time each caller spent in it (memoised; a call cycle counts as "other")."""
    if func in memo:
        return memo[func]
    cat = _category(func[0])
    callers = stats[func][4] if func in stats else {}
    if cat is not None or not callers:
        out = {cat or "other": 1.0}
    elif func in active:
        return {"other": 1.0}
    else:
        active.add(func)
        total = sum(v[3] for v in callers.values())
        out: dict[str, float] = {}
        for caller, v in callers.items():
            w = (v[3] / total) if total > 0 else 1.0 / len(callers)
            for c, f in (_shares(stats, caller, memo, active) if caller in stats else {"other": 1.0}).items():
                out[c] = out.get(c, 0.0) + w * f
        active.discard(func)
    memo[func] = out
    return out


def job_breakdown(prof_path: str | Path) -> dict[str, float]:
    """Seconds per category of one job's ``.prof`` (own time, inclusive of uncategorised callees)."""
    import pstats

    stats = pstats.Stats(str(prof_path)).stats
    acc: dict[str, float] = {}
    memo: dict = {}
    for func, (_, _, tt, _, _) in stats.items():
        if tt > 0:
            for c, f in _shares(stats, func, memo, set()).items():
                acc[c] = acc.get(c, 0.0) + tt * f
    return acc


def breakdown(root: str | Path) -> list[dict]:
    """One row per rule: jobs, startup seconds and seconds per category, summed over its jobs."""
    rows: dict[str, dict] = {}
    for meta in sorted(Path(root).glob("*/*.json")):
        info = json.loads(meta.read_text())
        prof = meta.with_suffix(".prof")
        if not prof.exists():
            continue
        row = rows.setdefault(info["rule"], {"rule": info["rule"], "jobs": 0, "startup (interpreter, imports)": 0.0, "total": 0.0})
        row["jobs"] += 1
        row["startup (interpreter, imports)"] += info["startup_s"]
        row["total"] += info["startup_s"] + info["profiled_s"]
        for cat, sec in job_breakdown(prof).items():
            row[cat] = row.get(cat, 0.0) + sec
    return sorted(rows.values(), key=lambda r: -r["total"])


def markdown(rows: list[dict]) -> str:
    """The breakdown as a Markdown table (seconds, summed over jobs), with a total row."""
    cats = ["startup (interpreter, imports)"] + [c for c, _ in CATEGORIES] + ["other"]
    head = "| rule | jobs | total s | " + " | ".join(cats) + " |"
    lines = [head, "|" + "---|" * (3 + len(cats))]
    tot = {c: 0.0 for c in cats}
    for r in rows:
        lines.append(f"| {r['rule']} | {r['jobs']} | {r['total']:.1f} | " + " | ".join(f"{r.get(c, 0.0):.1f}" for c in cats) + " |")
        for c in cats:
            tot[c] += r.get(c, 0.0)
    all_total = sum(r["total"] for r in rows)
    lines.append(f"| **all** | {sum(r['jobs'] for r in rows)} | {all_total:.1f} | " + " | ".join(f"{tot[c]:.1f}" for c in cats) + " |")
    return "\n".join(lines)


if __name__ == "__main__":  # python -m scintrack.profiling <dir>
    print(markdown(breakdown(sys.argv[1])))
