"""Data rule entry point: generate one versioned CSM training dataset."""

from scintrack import jobcode
from scintrack.data.synthetic import csm_training_dataset, csm_training_version
from scintrack.errors import InputError
from scintrack.io import provenance, write_netcdf

sm = snakemake  # noqa: F821 (injected by Snakemake)
log = jobcode.begin(sm, "csm_training_set")
params = dict(sm.params.dataset)
version = csm_training_version(params)
if version != sm.wildcards.version:
    raise InputError(
        f"{sm.output[0]}: the config gives version {version} for S4={params['s4']:g}; "
        "request that path (old versions are kept but never regenerated with new parameters)"
    )
ds = csm_training_dataset(params)
ds.attrs.update(provenance(config=params, seed=params["seed"], extra={"params": params}))
digest = write_netcdf(ds, sm.output[0])
log.info("wrote %s (content sha256 %s)", sm.output[0], digest)
