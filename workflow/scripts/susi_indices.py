"""Susi 2014 rule entry point: S4, Phi60, Phi3 and T, p of one trace scenario (Figs. 3 and 6)."""

from scintrack import jobcode
from scintrack.experiments.susi_indices import scenario_indices
from scintrack.experiments.traces import scenario_trace
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "susi_indices")
run = sm.params.run
exp = run["experiment"]
idx = run["indices"]
scenario = exp["scenario"]
ts = float(exp["ts"])
trace, _, source = scenario_trace(open_dataset(sm.input.trace), scenario, ts)
(tracker,) = exp["tracker_names"]
ds = scenario_indices(
    scenario_name=exp["scenario_name"], scenario=scenario, trace=trace, tracker_name=tracker, tracker_spec=exp["trackers"][tracker],
    tracking=exp["tracking"], seed=int(exp["seed"]), ts=ts, trial=int(run["figure_trial"]), window_s=float(idx["window_s"]),
    phi3_window_s=float(idx["phi3_window_s"]), detrend_hz=float(idx["detrend_hz"]),
)
ds.attrs.update({"trace_source": source, "title": f"{exp['scenario_name']}: scintillation indices ({'SURROGATE' if source == 'surrogate' else 'REAL'} trace)"})
ds.attrs.update(provenance(config=run, seed=int(exp["seed"]), inputs=list(sm.input)))
write_netcdf(ds, sm.output[0])
log.info("%s: S4 %s, Phi60 %s", exp["scenario_name"], ds["s4_true"].values.round(2), ds["phi60_true"].values.round(2))
