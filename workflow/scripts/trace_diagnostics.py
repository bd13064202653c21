"""Sec. VI-E rule entry point: S4(t) and segment PACFs of every trace (Figs. 12-14)."""

from scintrack import jobcode
from scintrack.experiments.traces import trace_diagnostics
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "trace_diagnostics")
run = sm.params.run
events = {name: open_dataset(path) for name, path in sm.input.items()}
diag = trace_diagnostics(
    events, ts=float(run["ts"]), window_s=float(run["window_s"]), pacf_lags=int(run["pacf_lags"]), segment_s=float(run["segment_s"]),
)
diag["segment_event"] = diag["segment_event"].astype(str)
diag.attrs.update(provenance(config=run, inputs=list(sm.input)))
write_netcdf(diag, sm.output[0])
log.info("segments: %s", dict(zip(diag["segment"].values, diag["segment_s4"].values.round(3))))
