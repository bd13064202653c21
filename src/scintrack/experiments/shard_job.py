"""The experiment job of the workflow: every scenario of an experiment, each in blocks ("shards") of trials.

An experiment runs as one job (rule ``tracking_<experiment>``).  Each of its
scenarios runs its trials in ``shards`` contiguous blocks
(:func:`scintrack.batching.trial_blocks`), one after the other; each
block goes through an uncompressed NetCDF file and back (so the merge sees
exactly the types and values a file gives) and the blocks are merged by adding
their per-epoch sums (:func:`.merge.merged_result`).  The number of blocks is
part of the result: another split groups those sums differently, at the
rounding level.

Everything comes from the rule's params (:func:`scintrack.pipeline.params.experiment`);
the result records the hash of exactly those values.  A trace scenario (Susi
2014) also reads its trace: the AR models of its fitting part and the part it
tracks.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..batching import trial_blocks
from ..io import open_dataset, provenance, write_netcdf
from .merge import merged_result
from .runner import run_shard
from .scenario import effective_tracking, scenario_dynamics


@dataclass(frozen=True)
class ScenarioInputs:
    """What every block of a scenario reads: the AR look-up table and, for a trace scenario, the trace to track,
    the AR models of its fitting part and its source (read, and the models fitted, once per scenario)."""

    lut: xr.Dataset
    trace: tuple[np.ndarray, np.ndarray] | None = None
    trace_set: Any = None
    source: str | None = None

    @classmethod
    def read(cls, run: Mapping[str, Any], lut: str, trace: str | None) -> ScenarioInputs:
        if "trace" not in run["scenario"]:
            return cls(open_dataset(lut))
        from .traces import scenario_trace

        data, trace_set, source = scenario_trace(open_dataset(trace), run["scenario"], float(run["ts"]))
        return cls(open_dataset(lut), data, trace_set, source)


def shard_result(run: Mapping[str, Any], trials: Sequence[int], *, lut: str, trace: str | None = None, inputs: Sequence[str] = (),
                 progress: Callable[[str], object] | None = None) -> xr.Dataset:
    """One shard (``trials`` of the (experiment, scenario) of ``run``) with its attributes and provenance."""
    return _block(run, trials, ScenarioInputs.read(run, lut, trace), inputs, progress)


def _block(run: Mapping[str, Any], trials: Sequence[int], data: ScenarioInputs, inputs: Sequence[str],
           progress: Callable[[str], object] | None) -> xr.Dataset:
    scenario = run["scenario"]
    ds = run_shard(
        scenario_name=run["scenario_name"], scenario=scenario, tracker_names=list(run["tracker_names"]), tracker_specs=run["trackers"],
        tracking=run["tracking"], lut=data.lut, seed=int(run["seed"]), ts=float(run["ts"]), nspa=int(run["nspa"]),
        warmup_s=float(run["warmup_s"]), trials=list(trials), trace=data.trace, trace_set=data.trace_set, progress=progress,
    )
    tracking = effective_tracking(scenario, run["tracking"])
    fd0, fr = scenario_dynamics(scenario, tracking)
    ds.attrs.update({"cn0_dbhz": float(scenario.get("cn0_dbhz", tracking.cn0_dbhz)), "fd0_hz": fd0, "fr_hz_s": fr, "ts": float(run["ts"])})
    if data.source is not None:
        ds.attrs.update({"trace_source": data.source, "trace_name": scenario["trace"]["name"],
                         "trace_phase_scale": float(scenario["trace"].get("phase_scale", 1.0)),
                         "title": f"{run['scenario_name']}: {'SURROGATE' if data.source == 'surrogate' else 'REAL'} scintillation trace"})
    ds.attrs.update(provenance(config={**run, "trials": list(trials)}, seed=int(run["seed"]), inputs=list(inputs),
                               extra={"experiment": run["experiment"]}))
    return ds


def scenario_result(run: Mapping[str, Any], *, lut: str, trace: str | None = None, inputs: Sequence[str] = (),
                    progress: Callable[[str], object] | None = None) -> xr.Dataset:
    """All trials of an (experiment, scenario): its blocks of trials run one after the other and merged.

    The look-up table and the trace are read (and a trace's AR models fitted) once for all blocks.  Each
    block is written uncompressed to a temporary file and read back before the merge (zlib changes no
    value; an uncompressed file is written and read about 4x faster), and a block's arrays are freed
    before the next block runs, so the job holds one block's simulation at a time.
    """
    blocks = trial_blocks(int(run["n_trials"]), int(run["shards"]))
    data = ScenarioInputs.read(run, lut, trace)
    with tempfile.TemporaryDirectory(prefix="scintrack-shards-") as tmp:
        shards = []
        for k, trials in enumerate(blocks):
            path = Path(tmp) / f"shard-{k}.nc"
            write_netcdf(_block(run, trials, data, inputs, progress), path, compress=False)
            shards.append(open_dataset(path))  # loaded into memory, file closed
            if progress is not None and len(blocks) > 1:
                progress(f"{run['scenario_name']}: block {k + 1}/{len(blocks)} (trials {trials[0]}..{trials[-1]})")
    return merged_result(shards, run, inputs)
