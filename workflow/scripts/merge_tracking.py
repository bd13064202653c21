"""Experiment rule entry point: merge shards into one result with statistics."""

from scintrack import runlog
from scintrack.experiments.merge import merge
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], "tracking_merge")
run = sm.params.run
result = merge([open_dataset(p) for p in sm.input])
result.attrs.update(provenance(config=run, seed=int(run["seed"]), inputs=list(sm.input), extra={"experiment": run["experiment"]}))
if "trace" in run["scenario"]:
    source = result.attrs.get("trace_source", "unknown")
    data = "SYNTHETIC SURROGATE scintillation trace" if source == "surrogate" else f"{source} scintillation trace"
else:
    data = "synthetic CSM data" if run["scenario"].get("segments") else "no scintillation"
result.attrs["title"] = f"{run['experiment']}: {run['scenario_name']} ({int(result['n_trials'])} trials, {data})"
write_netcdf(result, sm.output[0])
log.info("merged %d shards", len(sm.input))
