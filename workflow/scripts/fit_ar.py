"""AR rule entry point: fit AR models to one training dataset."""

from scintrack.pipeline.job_client import delegate

delegate(snakemake.threads)  # noqa: F821 - run in a fork of the warm job server if the run has one (scintrack.pipeline.job_server)

from scintrack import runlog
from scintrack.io import open_dataset, provenance, write_netcdf
from scintrack.models.lut import fit_training_set

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], "ar_fit")
ar = sm.params.fit["ar_models"]
train = open_dataset(sm.input.train)
wrapped = sm.params.fit.get("phase", "unwrapped") == "wrapped"
reuse = open_dataset(sm.input.unwrapped) if "unwrapped" in sm.input.keys() else None  # its amplitude fits (same series)
fits = fit_training_set(train, ar["max_order"], ar["pacf_lags"], ar["pacf_alpha"], ar["pacf_lengths_s"], wrap_phase=wrapped, reuse=reuse, progress=log.info)
if wrapped:
    fits.attrs["phase_fitted"] = "wrapped angle(exp(j theta)) (reading R5)"
fits.attrs.update(provenance(config=sm.params.fit, inputs=list(sm.input)))
fits.attrs["ts"] = train.attrs["ts"]
write_netcdf(fits, sm.output[0])
log.info("fitted %s", sm.input[0])
