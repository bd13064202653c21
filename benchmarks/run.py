"""Run every benchmark of benchmarks/ and print / write one table.

    .venv/bin/python benchmarks/run.py [--quick] [--csv benchmarks/results.csv]

Benchmarks: the trackers (:mod:`bench_trackers`: every compiled kernel, its
numpy reference and its per-trial loop, the AEKF-AR's flop-limited rate), the
GPS E/P/L correlator model (:mod:`bench_gps_correlator`) and the CSM generator
and AR fits (:mod:`bench_csm_ar`).  Default sizes are the paper-scale ones
(trackers at batch 500 x 5000 epochs, best of 3); ``--quick`` runs tiny sizes
once (a smoke test of the machinery; its rates mean little).

Columns: benchmark, item, rate, unit, ratio (to the row's baseline), baseline,
target, met (the target by the wall-clock rate), cpu_rate (the same runs over
CPU time: what one core delivers while it runs this process, the number to
read on a shared machine), met_cpu, note.  The CSV is written atomically
(a temporary file in the same folder, then renamed).
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import bench_csm_ar  # noqa: E402
import bench_gps_correlator  # noqa: E402
import bench_trackers  # noqa: E402
import machine  # noqa: E402

COLUMNS = ("benchmark", "item", "rate", "unit", "ratio", "baseline", "target", "met", "cpu_rate", "met_cpu", "note")

SIZES = {
    False: dict(trackers=dict(trials=500, epochs=5000, loop_trials=10, repeat=3), gps=dict(trials=100, seconds=240.0, svs=1, chunk=10),
                csm=dict(trials=16, epochs=30_000, repeat=3)),
    True: dict(trackers=dict(trials=40, epochs=300, loop_trials=2, repeat=1), gps=dict(trials=2, seconds=0.5, svs=1, chunk=2),
               csm=dict(trials=2, epochs=2000, repeat=1)),
}


def collect(quick: bool, log=print) -> list[dict]:
    sizes = SIZES[quick]
    rows = []
    log(f"trackers: {sizes['trackers']}")
    rows += bench_trackers.run(**sizes["trackers"], log=log)
    log(f"gps correlator: {sizes['gps']}")
    rows += bench_gps_correlator.run(**sizes["gps"], log=lambda s: None)
    log(f"csm / ar: {sizes['csm']}")
    rows += bench_csm_ar.run(**sizes["csm"], log=lambda s: None)
    return [{c: r.get(c, "") for c in COLUMNS} for r in rows]


def fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def table(rows: list[dict]) -> str:
    shown = ("benchmark", "item", "rate", "unit", "ratio", "target", "met", "cpu_rate", "met_cpu")
    cells = [[fmt(r[c]) for c in shown] for r in rows]
    width = [max(len(c), *(len(x[i]) for x in cells)) for i, c in enumerate(shown)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(shown, width))]
    lines += ["  ".join(x.ljust(w) for x, w in zip(line, width)) for line in cells]
    return "\n".join(lines)


def write_csv(rows: list[dict], path: Path) -> None:
    """Atomically: a temporary file next to ``path``, then os.replace."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=COLUMNS)
            w.writeheader()
            for r in rows:
                w.writerow({c: (repr(r[c]) if isinstance(r[c], float) and math.isfinite(r[c]) else r[c]) for c in COLUMNS})
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="tiny sizes, one run each (a test of the machinery)")
    ap.add_argument("--csv", type=Path, default=HERE / "results.csv", help="where to write the table (default benchmarks/results.csv)")
    args = ap.parse_args(argv)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    cores = os.cpu_count() or 1
    print(machine.peak().describe())
    print(f"load average {load:.2f} on {cores} cores" + ("  (shared machine: read cpu_rate / met_cpu)" if load > 0.5 * cores else ""))
    rows = collect(args.quick)
    print(table(rows))
    write_csv(rows, args.csv)
    print(f"wrote {args.csv}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
