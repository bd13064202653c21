"""Data rule entry point: generate one versioned SURROGATE event (phase screen)."""

from scintrack import jobcode
from scintrack.data.surrogate import GENERATOR, surrogate_event, surrogate_version
from scintrack.errors import InputError
from scintrack.io import provenance, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "surrogate_event")
params = dict(sm.params.dataset)
version = surrogate_version(params)
if version != sm.wildcards.version:
    raise InputError(f"{sm.output[0]}: the config gives version {version} for {params['event']}; request that path")
try:
    ds = surrogate_event(params)
except ValueError as exc:  # an unreachable S4 / sigma_phi target: name the setting
    setting = getattr(sm.params, "setting", None) or f"real_traces.surrogate.events.{params['event']}"
    raise InputError(f"{setting}: {exc}") from None
ds.attrs.update({"dataset_name": f"surrogate_{params['event']}", "dataset_version": version, "generator": GENERATOR})
ds.attrs.update(provenance(config=params, seed=params["seed"], extra={"params": params}))
digest = write_netcdf(ds, sm.output[0])
log.info("wrote %s: mean S4 %s, sigma_phi %s (content %s)", sm.output[0], ds["mean_s4"].values.round(3), ds["mean_sigma_phi"].values.round(3), digest)
