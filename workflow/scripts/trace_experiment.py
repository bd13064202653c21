"""Sec. VI-E rule entry point: the static and the dynamics experiment on one event; every setting from ``params``."""

from scintrack import jobcode
from scintrack.experiments.traces import dynamics_experiment, static_experiment
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, sm.rule)
trace = open_dataset(sm.input.trace)
models = open_dataset(sm.input.models)


def common(run):
    return dict(tracking=run["tracking"], seed=int(run["seed"]), ts=float(run["ts"]), fit_s=float(run["fit_s"]), eval_s=float(run["eval_s"]),
                trials=range(int(run["trials"])))


def finish(ds, run, inputs, output):
    ds.attrs.update({"fd0_hz": float(run["tracking"]["fd0_hz"]), "fr_hz_s": float(run["tracking"]["fr_hz_s"])})
    ds.attrs.update(provenance(config=run, seed=int(run["seed"]), inputs=inputs))
    write_netcdf(ds, output)


run = sm.params.static
(name,) = run["tracker_names"]
finish(static_experiment(trace, models, tracker_name=name, tracker_spec=run["trackers"][name], **common(run)), run,
       [sm.input.trace, sm.input.models], sm.output.static)
log.info("static experiment on %s (%s) done", trace.attrs["event"], trace.attrs["source"])

run = sm.params.dynamics
ds = dynamics_experiment(trace, models, tracker_names=list(run["tracker_names"]), tracker_specs=run["trackers"], lut=open_dataset(sm.input.lut),
                         rmse_start_s=float(run["rmse_start_s"]), **common(run))
finish(ds, run, [sm.input.trace, sm.input.models, sm.input.lut], sm.output.dynamics)
log.info("dynamics experiment on %s (%s) done", trace.attrs["event"], trace.attrs["source"])
