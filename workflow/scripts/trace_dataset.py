"""Data rule entry point: validate a real trace and write it in the canonical format."""

from scintrack import jobcode
from scintrack.data.traces import TraceFormatError, load_trace
from scintrack.io import content_hash, provenance, sha256_file, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "trace_dataset")
event = sm.wildcards.event
run = sm.params.trace
try:
    ds = load_trace(sm.input[0], list(run["bands"]), float(run["ts"]), event=event, source="real")
except TraceFormatError as exc:  # name the user's file (the input is its sha256-verified copy): that is the one to fix
    source = sm.config["real_traces"]["sources"].get(event, {})
    origin = source.get("path") or source.get("url") or sm.input[0]
    raise TraceFormatError(str(exc).replace(str(sm.input[0]), f"{origin} (copied to {sm.input[0]})", 1)) from None
ds.attrs.update(provenance(config=run, seed=None, inputs=list(sm.input)))
ds.attrs.update({"dataset_name": f"jrc_hanoi_{event}", "dataset_version": sha256_file(sm.input[0])[:12], "generator": "", "generator_version": "", "params": "{}"})
write_netcdf(ds, sm.output[0])
log.info("%s: %d samples, bands %s, content %s", event, ds.sizes["time"], list(ds["band"].values), content_hash(ds)[:12])
