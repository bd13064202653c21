"""The experiment jobs of the workflow: one shard of trials, and one whole (experiment, scenario).

An (experiment, scenario) whose trials are split into ``shards > 1`` runs as
one ``tracking_shard`` job per block of trials plus one ``tracking_merge``.
An experiment with ``shards: 1`` runs as one job that calls
:func:`single_result` for each of its scenarios: the shard and the merge in
one process.  The single result is the merge of its one shard after an exact
NetCDF round trip, so it has the content of the two-job path bit for bit
(``tests/test_speed_paths.py``).

Everything comes from the rule's params (:func:`scintrack.pipeline.params.experiment`,
plus the shard's ``trials``); the result records the hash of exactly those values.
A trace scenario (Susi 2014) also reads its trace: the AR models of its fitting
part and the part it tracks.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import xarray as xr

from ..io import open_dataset, provenance, write_netcdf
from .merge import merged_result
from .runner import run_shard
from .scenario import effective_tracking, scenario_dynamics


def shard_result(run: Mapping[str, Any], trials: Sequence[int], *, lut: str, trace: str | None = None, inputs: Sequence[str] = (),
                 progress: Callable[[str], object] | None = None) -> xr.Dataset:
    """One shard (``trials`` of the (experiment, scenario) of ``run``) with its attributes and provenance."""
    scenario = run["scenario"]
    trace_data = trace_set = source = None
    if "trace" in scenario:
        from .traces import scenario_trace

        trace_data, trace_set, source = scenario_trace(open_dataset(trace), scenario, float(run["ts"]))
    ds = run_shard(
        scenario_name=run["scenario_name"], scenario=scenario, tracker_names=list(run["tracker_names"]), tracker_specs=run["trackers"],
        tracking=run["tracking"], lut=open_dataset(lut), seed=int(run["seed"]), ts=float(run["ts"]), nspa=int(run["nspa"]),
        warmup_s=float(run["warmup_s"]), trials=list(trials), trace=trace_data, trace_set=trace_set, progress=progress,
    )
    tracking = effective_tracking(scenario, run["tracking"])
    fd0, fr = scenario_dynamics(scenario, tracking)
    ds.attrs.update({"cn0_dbhz": float(scenario.get("cn0_dbhz", tracking.cn0_dbhz)), "fd0_hz": fd0, "fr_hz_s": fr, "ts": float(run["ts"])})
    if source is not None:
        ds.attrs.update({"trace_source": source, "trace_name": scenario["trace"]["name"],
                         "title": f"{run['scenario_name']}: {'SURROGATE' if source == 'surrogate' else 'REAL'} scintillation trace"})
    ds.attrs.update(provenance(config={**run, "trials": list(trials)}, seed=int(run["seed"]), inputs=list(inputs),
                               extra={"experiment": run["experiment"]}))
    return ds


def single_result(run: Mapping[str, Any], *, lut: str, trace: str | None = None, inputs: Sequence[str] = (),
                  progress: Callable[[str], object] | None = None) -> xr.Dataset:
    """All trials of an (experiment, scenario) in one shard, merged: what ``tracking_shard`` + ``tracking_merge`` give.

    The shard goes through a NetCDF file and back first, exactly as between
    the two jobs, so that the merge sees the same types and values.  Both write
    that hand-off uncompressed (the result itself is compressed): zlib changes
    no value, and the hand-off is written ~4x and read ~4x faster (a 40-MB
    cycle-slip result: written in 0.10 s instead of 0.45, read in 0.025 s
    instead of 0.10).
    """
    shard = shard_result(run, range(int(run["n_trials"])), lut=lut, trace=trace, inputs=inputs, progress=progress)
    with tempfile.TemporaryDirectory(prefix="scintrack-shard-") as tmp:
        path = Path(tmp) / "shard-0.nc"
        write_netcdf(shard, path, compress=False)
        reread = open_dataset(path)  # loaded into memory, file closed
    return merged_result([reread], run, inputs)
