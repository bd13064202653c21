"""Experiment rule entry point: every scenario of an experiment, each run in its blocks of trials and merged into its own result
(:func:`scintrack.experiments.shard_job.scenario_result`)."""

from scintrack import runlog
from scintrack.experiments.shard_job import scenario_result
from scintrack.io import write_netcdf

sm = snakemake  # noqa: F821
runs = sm.params.runs
log = runlog.setup(sm.log[0], f"tracking_{next(iter(runs.values()))['experiment']}")
for (scenario, run), output in zip(runs.items(), sm.output, strict=True):
    inputs = [sm.input.lut, *([sm.input[f"trace_{scenario}"]] if f"trace_{scenario}" in sm.input.keys() else [])]
    result = scenario_result(run, lut=inputs[0], trace=inputs[1] if len(inputs) > 1 else None, inputs=inputs, progress=log.info)
    write_netcdf(result, output)
    log.info("%s/%s: %d trials in %d block(s)", run["experiment"], scenario, int(run["n_trials"]), int(run["shards"]))
