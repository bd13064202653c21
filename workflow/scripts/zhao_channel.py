"""Result rule entry point: one satellite channel of the jamming receiver (all trials)."""

from scintrack import jobcode
from scintrack.experiments.gps_channel_result import channel_result
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, f"zhao_channel prn {sm.wildcards.prn}")
params = dict(sm.params.receiver)
ds = open_dataset(sm.input.dataset)
out = channel_result(ds, int(sm.wildcards.prn), params, sm.input.ephemerides, log=log.info, trial_batch=int(sm.resources.trial_batch),
                     prediction=open_dataset(sm.input.prediction) if hasattr(sm.input, "prediction") else None)  # a clean-scenario reading has none
out.attrs.update(provenance(config=params, seed=params["seed"], inputs=[sm.input.dataset]))
digest = write_netcdf(out, sm.output[0])
log.info("wrote %s (content sha256 %s)", sm.output[0], digest)
