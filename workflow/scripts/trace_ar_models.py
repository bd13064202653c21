"""Sec. VI-E rule entry point: AR models fitted on the first part of one trace."""

from scintrack import runlog
from scintrack.experiments.traces import fit_trace_models
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], "trace_ar_models")
cfg = sm.config
ds = open_dataset(sm.input[0])
models = fit_trace_models(ds, fit_s=float(cfg["real_traces"]["fit_s"]), ts=float(cfg["sampling"]["ts"]))
models.attrs.update(provenance(config=cfg, inputs=list(sm.input)))
write_netcdf(models, sm.output[0])
log.info("%s: phase orders %s, fit S4 %s", models.attrs["event"], models["phase_order"].values, models["s4_fit"].values.round(3))
