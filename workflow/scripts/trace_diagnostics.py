"""Sec. VI-E rule entry point: S4(t) and segment PACFs of every trace (Figs. 12-14)."""

from scintrack import runlog
from scintrack.experiments.traces import trace_diagnostics
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], "trace_diagnostics")
cfg = sm.config
rt = cfg["real_traces"]
events = {name: open_dataset(path) for name, path in sm.input.items()}
diag = trace_diagnostics(
    events, ts=float(cfg["sampling"]["ts"]), window_s=float(rt["s4_window_s"]), pacf_lags=int(cfg["figures"]["vila_valls_2018"]["pacf_lags_shown"]),
    segment_s=float(rt["pacf_segment_s"]),
)
diag["segment_event"] = diag["segment_event"].astype(str)
diag.attrs.update(provenance(config=cfg, inputs=list(sm.input)))
write_netcdf(diag, sm.output[0])
log.info("segments: %s", dict(zip(diag["segment"].values, diag["segment_s4"].values.round(3))))
