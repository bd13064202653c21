"""Experiment rule entry point: one shard of a tracking Monte Carlo (:mod:`scintrack.experiments.shard_job`)."""

from scintrack import runlog
from scintrack.experiments.shard_job import shard_result
from scintrack.io import write_netcdf

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], "tracking_shard")
run = sm.params.run
ds = shard_result(run, run["trials"], lut=sm.input.lut, trace=sm.input.get("trace"), inputs=list(sm.input), progress=log.info)
write_netcdf(ds, sm.output[0], compress=False)  # a temp() hand-off to tracking_merge: ~4x faster to write, ~4x to read, ~2.5x larger
log.info("%s/%s: trials %s..%s", run["experiment"], run["scenario_name"], run["trials"][0], run["trials"][-1])
