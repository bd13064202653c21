"""Experiment rule entry point: merge shards into one result with statistics."""

from scintrack import runlog
from scintrack.experiments.merge import merged_result
from scintrack.io import open_dataset, write_netcdf

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], "tracking_merge")
result = merged_result([open_dataset(p) for p in sm.input], sm.params.run, list(sm.input))
write_netcdf(result, sm.output[0])
log.info("merged %d shards", len(sm.input))
