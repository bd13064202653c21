"""benchmarks/run.py --quick: one table of every benchmark, written as CSV (a test of the machinery, not of speed)."""

from __future__ import annotations

import csv
import math
import os
import subprocess
import sys

from conftest import REPO

COLUMNS = ["benchmark", "item", "rate", "unit", "ratio", "baseline", "target", "met", "cpu_rate", "met_cpu", "note"]


def test_run_quick_writes_the_table_with_a_positive_finite_rate_on_every_row(tmp_path):
    out = tmp_path / "results.csv"
    proc = subprocess.run([sys.executable, str(REPO / "benchmarks" / "run.py"), "--quick", "--csv", str(out)],
                          capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    with open(out, newline="") as f:
        reader = csv.DictReader(f)
        assert reader.fieldnames == COLUMNS
        rows = list(reader)
    benchmarks = {r["benchmark"] for r in rows}
    assert benchmarks == {"trackers", "gps_correlator", "csm_ar"}
    for r in rows:
        rate = float(r["rate"])
        assert math.isfinite(rate) and rate > 0, r
        assert r["met"] in ("", "yes", "no") and r["met_cpu"] in ("", "yes", "no"), r
    kernels = [r["item"] for r in rows if r["benchmark"] == "trackers" and r["item"].endswith(" kernel")]
    assert {"AEKF-AR kernel", "MM KF kernel", "PLL kernel", "SAKF PLL kernel"} <= set(kernels)
    assert all(r["target"] and r["met"] for r in rows if r["item"] in kernels)
    flop = [r for r in rows if r["item"].startswith("AEKF-AR flop-limited")]
    assert len(flop) == 1 and "Gflop/s" in flop[0]["note"]
    assert not list(tmp_path.glob(".results.csv.*"))  # the temporary file was renamed
    assert "AEKF-AR kernel" in proc.stdout


def test_benchmark_modules_run_alone_use_the_packages_versioned_numba_cache(tmp_path):
    """Each benchmark script imported on its own (as ``python benchmarks/bench_trackers.py`` does) must compile into
    :mod:`scintrack.numba_cache`'s folder, not into ``__pycache__``, where numba checks a kernel against its own file
    only and would run a kernel built from an older version of a block it inlines (seen: a stale PLL kernel)."""
    for module in ("bench_trackers", "bench_gps_correlator", "machine", "bench_csm_ar"):
        code = (f"import sys; sys.path.insert(0, {str(REPO / 'benchmarks')!r}); import {module}; "
                "from scintrack import numba_cache; from scintrack.trackers import pll; "
                "print(pll.pll_kernel._cache._cache_path); print(numba_cache.cache_dir())")
        env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
        env["SCINTRACK_NUMBA_CACHE_ROOT"] = str(tmp_path)
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr[-2000:]
        cache_path, folder = proc.stdout.split()
        assert cache_path.startswith(folder) and folder.startswith(str(tmp_path)), (module, cache_path, folder)
