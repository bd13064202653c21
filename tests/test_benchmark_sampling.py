"""Snakemake's benchmark sampler, made light (scintrack.pipeline.benchmark_sampling; issue 14).

One sample of a live process that holds a known amount of memory must give
its RSS (statm) and its CPU time, leave USS/PSS unset, and a process that is
gone must be recorded as gone, not as an error.
"""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

benchmark = pytest.importorskip("snakemake.benchmark")

from scintrack.pipeline import benchmark_sampling  # noqa: E402

HOLD_MB = 300
CHILD = (
    "import sys, time\n"
    f"block = bytearray({HOLD_MB} * 2**20)\n"
    "for i in range(0, len(block), 4096): block[i] = 1\n"  # touch every page: resident
    "t = time.process_time()\n"
    "while time.process_time() - t < 0.3: pass\n"  # some CPU time to report
    "print('ready', flush=True)\n"
    "sys.stdin.read()\n"
)


def test_install_replaces_the_samplers_record_update():
    assert benchmark_sampling.install()
    assert benchmark.BenchmarkTimer._update_record is benchmark_sampling._update_record


def test_one_sample_of_a_live_process_gives_its_rss_and_cpu_time_and_no_uss_pss():
    proc = subprocess.Popen([sys.executable, "-c", CHILD], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "ready"
        record = benchmark.BenchmarkRecord()
        timer = benchmark.BenchmarkTimer(proc.pid, record)
        benchmark_sampling._update_record(timer)
        time.sleep(0.05)
        benchmark_sampling._update_record(timer)
    finally:
        proc.communicate("")
    assert record.data_collected and not record.errors
    assert HOLD_MB <= record.max_rss < HOLD_MB + 200, record.max_rss
    assert record.max_vms >= record.max_rss
    assert record.max_uss is None and record.max_pss is None  # written as "-" in the TSV
    assert 0.3 <= record.cpu_time < 5.0, record.cpu_time
    record.running_time = 1.0  # set by snakemake.benchmark.benchmarked() when the job ends
    fields = dict(zip(record.get_header(), record.to_tsv(False).split("\t")))
    assert fields["max_uss"] == "-" and fields["max_pss"] == "-"
    assert float(fields["max_rss"]) >= HOLD_MB


def test_a_process_that_is_gone_is_recorded_as_gone():
    proc = subprocess.Popen([sys.executable, "-c", "print('ready', flush=True); input()"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "ready"
    record = benchmark.BenchmarkRecord()
    timer = benchmark.BenchmarkTimer(proc.pid, record)
    proc.communicate("\n")
    benchmark_sampling._update_record(timer)
    assert record.process_gone and not record.data_collected and not record.errors
