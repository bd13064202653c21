"""Experiment rule entry point: one shard of a tracking Monte Carlo.

Everything comes from ``params.run`` (scintrack.pipeline.params.experiment
plus the shard's trials); the result records the hash of exactly those values.
A trace scenario (Susi 2014) also reads its trace (``input.trace``): the AR
models of its fitting part and the part it tracks.
"""

from scintrack import runlog
from scintrack.experiments.runner import run_shard
from scintrack.experiments.scenario import effective_tracking, scenario_dynamics
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], "tracking_shard")
run = sm.params.run
lut = open_dataset(sm.input.lut)
scenario = run["scenario"]
trace = trace_set = None
source = None
if "trace" in scenario:
    from scintrack.experiments.traces import scenario_trace

    trace, trace_set, source = scenario_trace(open_dataset(sm.input.trace), scenario, float(run["ts"]))
ds = run_shard(
    scenario_name=run["scenario_name"],
    scenario=scenario,
    tracker_names=list(run["tracker_names"]),
    tracker_specs=run["trackers"],
    tracking=run["tracking"],
    lut=lut,
    seed=int(run["seed"]),
    ts=float(run["ts"]),
    nspa=int(run["nspa"]),
    warmup_s=float(run["warmup_s"]),
    trials=list(run["trials"]),
    trace=trace,
    trace_set=trace_set,
    progress=log.info,
)
tracking = effective_tracking(scenario, run["tracking"])
fd0, fr = scenario_dynamics(scenario, tracking)
ds.attrs.update({"cn0_dbhz": float(scenario.get("cn0_dbhz", tracking["cn0_dbhz"])), "fd0_hz": fd0, "fr_hz_s": fr, "ts": float(run["ts"])})
if source is not None:
    ds.attrs.update({"trace_source": source, "trace_name": scenario["trace"]["name"],
                     "title": f"{run['scenario_name']}: {'SURROGATE' if source == 'surrogate' else 'REAL'} scintillation trace"})
ds.attrs.update(provenance(config=run, seed=int(run["seed"]), inputs=list(sm.input), extra={"experiment": run["experiment"]}))
write_netcdf(ds, sm.output[0])
log.info("%s/%s: trials %s..%s", run["experiment"], run["scenario_name"], run["trials"][0], run["trials"][-1])
