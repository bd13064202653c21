"""Experiment rule entry point: every scenario of an experiment, each run in its blocks of trials and merged into its own result
(:func:`scintrack.experiments.shard_job.scenario_result`)."""

from scintrack import jobcode
from scintrack.experiments.shard_job import scenario_result
from scintrack.io import write_netcdf

sm = snakemake  # noqa: F821
runs = sm.params.runs
log = jobcode.begin(sm, f"tracking_{next(iter(runs.values()))['experiment']}")
for (scenario, run), output in zip(runs.items(), sm.output, strict=True):
    trace = sm.input.get(f"trace_{scenario}")  # a trace scenario's trace (Susi 2014), else None
    inputs = [sm.input.lut] if trace is None else [sm.input.lut, trace]
    result = scenario_result(run, lut=sm.input.lut, trace=trace, inputs=inputs, progress=log.info)
    write_netcdf(result, output)
    log.info("%s/%s: %d trials in %d block(s)", run["experiment"], scenario, int(run["n_trials"]), int(run["shards"]))
