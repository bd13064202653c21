"""Sec. VI-E rule entry point: the static (rule trace_static) or dynamics
(rule trace_dynamics) experiment on one event; every setting from ``params.run``."""

from scintrack.pipeline.job_client import delegate

delegate(snakemake.threads)  # noqa: F821 - run in a fork of the warm job server if the run has one (scintrack.pipeline.job_server)

from scintrack import runlog
from scintrack.experiments.traces import dynamics_experiment, static_experiment
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], sm.rule)
run = sm.params.run
trace = open_dataset(sm.input.trace)
models = open_dataset(sm.input.models)
common = dict(
    tracking=run["tracking"], seed=int(run["seed"]), ts=float(run["ts"]), fit_s=float(run["fit_s"]), eval_s=float(run["eval_s"]),
    trials=range(int(run["trials"])),
)
if sm.rule == "trace_static":
    (name,) = run["tracker_names"]
    ds = static_experiment(trace, models, tracker_name=name, tracker_spec=run["trackers"][name], **common)
else:
    ds = dynamics_experiment(
        trace, models, tracker_names=list(run["tracker_names"]), tracker_specs=run["trackers"], lut=open_dataset(sm.input.lut),
        rmse_start_s=float(run["rmse_start_s"]), **common,
    )
ds.attrs.update({"fd0_hz": float(run["tracking"]["fd0_hz"]), "fr_hz_s": float(run["tracking"]["fr_hz_s"])})
ds.attrs.update(provenance(config=run, seed=int(run["seed"]), inputs=list(sm.input)))
write_netcdf(ds, sm.output[0])
log.info("%s on %s (%s) done", sm.rule, trace.attrs["event"], trace.attrs["source"])
