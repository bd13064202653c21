"""Data rule entry point: the jammed GPS L1 C/A scenario dataset (Zhao et al.)."""

from scintrack import jobcode
from scintrack.data.gps_jamming_build import build
from scintrack.data.gps_jamming_spec import gps_jamming_version
from scintrack.errors import InputError
from scintrack.io import provenance, write_netcdf

sm = snakemake  # noqa: F821 (injected by Snakemake)
log = jobcode.begin(sm, "gps_jamming_dataset")
params = dict(sm.params.dataset)
version = gps_jamming_version(params)
if not str(sm.output[0]).endswith(f"/{version}.nc"):
    raise InputError(f"{sm.output[0]}: the config gives version {version}; request that path")
try:
    ds = build(params, sm.input.ephemerides)
except ValueError as exc:
    raise InputError(f"gps_jamming: {exc}") from None
ds.attrs.update(provenance(config=params, seed=params["seed"], inputs=[sm.input.ephemerides], extra={"params": params}))
digest = write_netcdf(ds, sm.output[0])
log.info("wrote %s (content sha256 %s): window %s, PRNs %s, max GDOP %.2f", sm.output[0], digest, ds.attrs["window_start_utc"],
         list(ds["prn"].values), ds.attrs["window_max_gdop"])
