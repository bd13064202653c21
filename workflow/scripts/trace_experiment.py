"""Sec. VI-E rule entry point: the static (rule trace_static) or dynamics
(rule trace_dynamics) experiment on one event."""

from scintrack import runlog
from scintrack.experiments.traces import dynamics_experiment, static_experiment
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], sm.rule)
cfg = sm.config
rt = cfg["real_traces"]
ts = float(cfg["sampling"]["ts"])
trace = open_dataset(sm.input.trace)
models = open_dataset(sm.input.models)
common = dict(tracking=cfg["tracking"], seed=int(cfg["seed"]), ts=ts, fit_s=float(rt["fit_s"]), eval_s=float(rt["eval_s"]), trials=range(int(rt["trials"])))
if sm.rule == "trace_static":
    name = rt["static_tracker"]
    ds = static_experiment(trace, models, tracker_name=name, tracker_spec=cfg["trackers"][name], **common)
else:
    ds = dynamics_experiment(
        trace, models, tracker_names=list(rt["trackers"]), tracker_specs=cfg["trackers"], lut=open_dataset(sm.input.lut),
        rmse_start_s=float(rt["rmse_start_s"]), **common,
    )
ds.attrs.update(provenance(config=cfg, seed=int(cfg["seed"]), inputs=list(sm.input)))
write_netcdf(ds, sm.output[0])
log.info("%s on %s (%s) done", sm.rule, trace.attrs["event"], trace.attrs["source"])
