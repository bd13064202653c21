"""Threads, memory and run time of the computing rules, from measurements.

Every rule that computes declares ``threads: 1`` (no script uses more than
one core: numpy and numba loops, no thread or process pools) and
``resources: mem_mb=..., runtime=...`` (MB, minutes) from this module, so a
scheduler reserves what a job needs: the local one under a
``--resources mem_mb=`` cap (``--profile profiles/local``), SLURM through
``--mem`` and ``-t`` (``--profile profiles/slurm``).  Snakemake does not rerun
a job when its resources change, so editing the numbers recomputes nothing.

The numbers are measured (:data:`MEASURED`): the largest ``max_rss`` and wall
time over a rule's jobs in the ``benchmark:`` files of full runs with
``config/config.yaml`` on the project's 2-core machine (two jobs at a time);
the rules without a ``benchmark:`` were rerun with one in a scratch copy of a
finished run.  Declared memory is :data:`MEM_MARGIN` x max_rss, declared run
time :data:`RUNTIME_FACTOR` x wall and at least :data:`MIN_RUNTIME_MIN`
minutes (:func:`mem_mb_for`, :func:`runtime_for`).

Where the cost follows the config, the declaration scales with the job's
size: an experiment's job with the trials x epochs of its largest block
(memory) and its trials x epochs x trackers (time), a Zhao channel with its trials per batch x duration
(memory) and trials x duration (time), so a larger config asks for more
without an edit here.

To re-measure after a change of cost, run the full pipeline and
``python -m scintrack.pipeline.resources results/benchmarks``: it prints the
largest max_rss and wall per rule, to copy into :data:`MEASURED`.
"""

from __future__ import annotations

import csv
import math
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

MEM_MARGIN = 1.5  # declared memory = 1.5 x measured peak (rounded up to 100 MB)
RUNTIME_FACTOR = 4  # declared run time = 4 x measured wall (rounded up to minutes) ...
MIN_RUNTIME_MIN = 5  # ... and never below 5 minutes (start-up, a loaded or slower node)

# rule: (max_rss MB, wall s), the largest over the rule's jobs in full runs
# (the rules without a benchmark: one job at a time on a finished run's inputs).
MEASURED: dict[str, tuple[float, float]] = {
    "csm_training_set": (267.1, 5.3),
    "ar_fit": (196.6, 75.5),  # the unwrapped (33.3 s) and the wrapped (42.2 s) fits of one training set, measured as separate jobs
    "ar_lut": (102.3, 2.8),
    "ar_lut_wrapped": (102.3, 3.7),
    "ar_diagnostics": (188.4, 4.8),
    "vv_floors": (491.0, 27.0),  # the six Table III cells one after the other (4.5 s each)
    "surrogate_event": (231.8, 15.7),
    "trace_ar_models": (287.5, 5.1),
    "trace_diagnostics": (344.8, 5.9),
    "trace_tracking": (550.1, 21.4),  # the static (9.1 s) and the dynamics (12.3 s) experiment of one event, measured as separate jobs
    "susi_surrogate": (272.1, 28.7),
    "susi_indices": (332.7, 8.3),
    "susi_biscef_indices": (113.1, 1.6),
    "susi_index_trace": (308.5, 3.8),
    "susi_jitter_bound": (433.4, 14.5),
    "susi_akf_bandwidth": (275.0, 62.1),  # two scenarios x five AKFs x three Riccati solutions and impulse responses (a loaded machine)
    "susi_readings_loops": (350.8, 49.4),  # Susi readings: two scenarios x six KF PLLs x two impulse responses (21.8 CPU-s, at load 19)
    "gps_jamming_dataset": (407.3, 5.6),
    "gps_iq_recording": (389.2, 2.1),
    "zhao_cn0_estimates": (350.5, 1.8),
    "zhao_iq_spectrum": (459.3, 3.1),
    "zhao_channel": (1359.8, 37.3),  # full run, trial_batch 20
    "zhao_receiver": (374.1, 2.7),
    "zhao_bit_prediction": (242.5, 2.7),  # one run of the job on the full dataset
    "zhao_cn0_sweep_point": (1353.5, 89.4),
    "real_acquisition": (182.6, 14.2),  # the 12-MHz capture's search
    "real_tracking": (380.9, 11.1),  # the 0.5-s capture's seven satellites
}

# Blocks of trials of an experiment's job (rule tracking_<experiment>), fitted
# to measured blocks of the full and the smoke run: peak memory = SHARD_BASE_MB
# + SHARD_KB_PER_TRIAL_EPOCH x trials held x epochs (the simulated signals of the
# trials a block holds at once, scintrack.batching.trials_held; the CSM and AR
# worlds also hold the nspa sub-samples), wall = SHARD_START_S +
# SHARD_US_PER_FILTER_EPOCH x trials x epochs x trackers.  Largest measured:
# a cycle_slips block 602-657 MB (32 trials held), a susi_alpha block 1392 MB;
# the model's 990 and 1850 MB stay above both.
SHARD_BASE_MB = 350.0
SHARD_KB_PER_TRIAL_EPOCH = {"csm": 0.4, "ar": 0.4, "trace": 0.2}
SHARD_START_S = 10.0
SHARD_US_PER_FILTER_EPOCH = 2.0

# Zhao channels (rule zhao_channel), measured with trials 100, trial_batch 20
# and duration_s 240: peak memory = ZHAO_BASE_MB + the rest of the measured
# peak x (trial_batch x duration_s) / measured, wall = SHARD_START_S + the rest
# of the measured wall x (trials x duration_s) / measured.
ZHAO_MEASURED_SIZE = {"trials": 100, "trial_batch": 20, "duration_s": 240.0}
ZHAO_BASE_MB = 300.0


def mem_mb_for(max_rss_mb: float) -> int:
    """Memory to declare for a measured peak: MEM_MARGIN x it, rounded up to 100 MB."""
    return int(math.ceil(MEM_MARGIN * max_rss_mb / 100.0)) * 100


def runtime_for(wall_s: float) -> int:
    """Minutes to declare for a measured wall time: RUNTIME_FACTOR x it, at least MIN_RUNTIME_MIN."""
    return max(MIN_RUNTIME_MIN, int(math.ceil(RUNTIME_FACTOR * wall_s / 60.0)))


def mem_mb(rule: str) -> int:
    """Declared memory (MB) of a rule with a fixed cost."""
    return mem_mb_for(MEASURED[rule][0])


def runtime(rule: str) -> int:
    """Declared run time (minutes) of a rule with a fixed cost."""
    return runtime_for(MEASURED[rule][1])


def shard_size(config: Mapping[str, Any], experiment: str, scenario: str, shard: int) -> tuple[int, int, int, str]:
    """(trials, epochs, trackers, scintillation model) of one block of trials of a scenario."""
    from .params import shard_trials

    sc = config["scenarios"][scenario]
    ts = float(sc.get("ts", config["sampling"]["ts"]))
    epochs = int(round(float(sc["duration_s"]) / ts))
    trackers = len(config["experiments"][experiment]["trackers"])
    return len(shard_trials(config, experiment, shard)), epochs, trackers, str(sc.get("scintillation_model", "csm"))


def shard_mem_mb(config: Mapping[str, Any], experiment: str, scenario: str, shard: int) -> int:
    """Declared memory of one block of trials: its modelled peak x MEM_MARGIN (the same for 10x the trials: batches)."""
    from ..batching import trials_held

    trials, epochs, _, model = shard_size(config, experiment, scenario, shard)
    kb = SHARD_KB_PER_TRIAL_EPOCH.get(model, max(SHARD_KB_PER_TRIAL_EPOCH.values()))
    return mem_mb_for(SHARD_BASE_MB + kb * trials_held(trials, epochs) * epochs / 1000.0)


def _blocks(config: Mapping[str, Any], experiment: str):
    """(scenario, block) of every block of trials an experiment's job runs."""
    spec = config["experiments"][experiment]
    return [(scenario, k) for scenario in spec["scenarios"] for k in range(int(spec["shards"]))]


def experiment_mem_mb(config: Mapping[str, Any], experiment: str) -> int:
    """Declared memory of an experiment's job: its largest block of trials (the blocks and scenarios run one after the other)."""
    return max(shard_mem_mb(config, experiment, s, k) for s, k in _blocks(config, experiment))


def experiment_runtime(config: Mapping[str, Any], experiment: str) -> int:
    """Declared run time of an experiment's job: one start-up plus the modelled walls of all its blocks, x RUNTIME_FACTOR."""
    wall = 0.0
    for scenario, k in _blocks(config, experiment):
        trials, epochs, trackers, _ = shard_size(config, experiment, scenario, k)
        wall += SHARD_US_PER_FILTER_EPOCH * 1e-6 * trials * epochs * trackers
    return runtime_for(SHARD_START_S + wall)


def _zhao_scale(config: Mapping[str, Any], *keys: str) -> float:
    """Product of ``keys`` (zhao_receiver trials / trial_batch, gps_jamming duration_s) relative to the measured run."""
    values = {"trials": config["zhao_receiver"]["trials"], "trial_batch": config["zhao_receiver"]["trial_batch"],
              "duration_s": config["gps_jamming"]["duration_s"]}
    return math.prod(float(values[k]) / float(ZHAO_MEASURED_SIZE[k]) for k in keys)


def zhao_channel_mem_mb(config: Mapping[str, Any]) -> int:
    """Declared memory of a Zhao channel (every channel has the same size): scales with trials per batch x duration."""
    rss = MEASURED["zhao_channel"][0]
    return mem_mb_for(ZHAO_BASE_MB + (rss - ZHAO_BASE_MB) * _zhao_scale(config, "trial_batch", "duration_s"))


def zhao_channel_runtime(config: Mapping[str, Any]) -> int:
    """Declared run time of a Zhao channel: scales with trials x duration."""
    wall = MEASURED["zhao_channel"][1]
    return runtime_for(SHARD_START_S + (wall - SHARD_START_S) * _zhao_scale(config, "trials", "duration_s"))


def measured(benchmarks: str | Path) -> dict[str, tuple[float, float]]:
    """Largest (max_rss MB, wall s) per rule in a ``results/benchmarks`` folder (``<rule>.tsv`` or ``<rule>/.../*.tsv``)."""
    out: dict[str, tuple[float, float]] = {}
    root = Path(benchmarks)
    for path in sorted(root.rglob("*.tsv")):
        rule = path.relative_to(root).parts[0].removesuffix(".tsv")
        with path.open() as fh:
            rows = list(csv.DictReader(fh, delimiter="\t"))
        for row in rows:
            rss, wall = float(row["max_rss"]), float(row["s"])
            old = out.get(rule, (0.0, 0.0))
            out[rule] = (max(old[0], rss), max(old[1], wall))
    return out


if __name__ == "__main__":
    for name, (rss, wall) in sorted(measured(sys.argv[1] if len(sys.argv) > 1 else "results/benchmarks").items()):
        print(f"{name:24s} max_rss {rss:8.1f} MB  wall {wall:7.1f} s  -> mem_mb {mem_mb_for(rss):6d}  runtime {runtime_for(wall):4d} min")
