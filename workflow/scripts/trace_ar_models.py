"""Sec. VI-E rule entry point: AR models fitted on the first part of one trace."""

from scintrack import jobcode
from scintrack.experiments.traces import fit_trace_models
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "trace_ar_models")
run = sm.params.run
ds = open_dataset(sm.input[0])
models = fit_trace_models(ds, fit_s=float(run["fit_s"]), ts=float(run["ts"]))
models.attrs.update(provenance(config=run, inputs=list(sm.input)))
write_netcdf(models, sm.output[0])
log.info("%s: phase orders %s, fit S4 %s", models.attrs["event"], models["phase_order"].values, models["s4_fit"].values.round(3))
