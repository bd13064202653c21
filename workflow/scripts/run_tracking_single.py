"""Experiment rule entry point: a single-shard (experiment, scenario), run and merged in one job
(:func:`scintrack.experiments.shard_job.single_result`)."""

from scintrack.pipeline.job_client import delegate

delegate(snakemake.threads)  # noqa: F821 - run in a fork of the warm job server if the run has one (scintrack.pipeline.job_server)

from scintrack import runlog
from scintrack.experiments.shard_job import single_result
from scintrack.io import write_netcdf

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], "tracking_single")
run = sm.params.run
write_netcdf(single_result(run, lut=sm.input.lut, trace=sm.input.get("trace"), inputs=list(sm.input), progress=log.info), sm.output[0])
log.info("%s/%s: %d trials in one job", run["experiment"], run["scenario_name"], int(run["n_trials"]))
