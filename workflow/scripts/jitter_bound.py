"""Susi 2014 rule entry point: the jitter bound and the best third-order loop of each chapter scenario.

Writes ``results/susi_2014/jitter_bound.nc`` (one ``scenario`` row per
scenario of the chapter run; :func:`scintrack.experiments.prediction_bound.scenario_bound`).
The tracked phase is the scenario's: its trace (the same segment the
experiment tracks) and the receiver clock of trials 0.. of the experiment's
own seed stream; the loop sweep's thermal noise has its own stream.
"""

import numpy as np
import xarray as xr

from scintrack import jobcode
from scintrack.experiments.prediction_bound import LOOP_TRIALS, scenario_bound
from scintrack.experiments.scenario import clock_phase, effective_tracking, scenario_epochs
from scintrack.experiments.traces import scenario_trace
from scintrack.io import open_dataset, provenance, write_netcdf
from scintrack.seeding import rng_for

STREAM = "susi_jitter_bound"

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "susi_jitter_bound")
run = sm.params.run
seed = int(run["seed"])
parts = []
for (name, exp), path in zip(run["scenarios"].items(), sm.input.traces, strict=True):
    scenario, ts = exp["scenario"], float(exp["ts"])
    tracking = effective_tracking(scenario, exp["tracking"])
    (rho, theta), _, source = scenario_trace(open_dataset(path), scenario, ts)
    n = scenario_epochs(scenario, ts)
    rho, theta = rho[:n], theta[:n]
    trials = np.arange(LOOP_TRIALS)
    streams = str(scenario.get("realisations_of", name))  # the experiment's seed streams
    clock = (clock_phase(seed, f"scenario/{streams}/clock", trials, n, ts, str(scenario["clock"])) if scenario.get("clock")
             else np.zeros((trials.size, n)))
    noise = np.stack([rng_for(seed, f"{STREAM}/{name}", int(t)).standard_normal(n) for t in trials])
    cn0 = float(scenario.get("cn0_dbhz", tracking.cn0_dbhz))
    ds = scenario_bound(name=name, phase=theta, amplitude=rho, clock=clock, cn0_dbhz=cn0, ts=ts,
                        per_window=max(int(round(tracking.jitter_window_s / ts)), 1),
                        steady_start=int(round(tracking.steady_state_start_s / ts)), noise=noise)
    log.info("%s: bound %.4f rad (with fading %.4f), Wiener %.4f rad, best third-order loop %s Hz: %s rad", name, float(ds["bound_rad"]),
             float(ds["bound_fading_rad"]), float(ds["wiener_bound_rad"]), ds["best_bandwidth_hz"].values, ds["best_pll_jitter_rad"].values.round(4))
    per_scenario = {"cn0_dbhz": "dB-Hz", "window_s": "s", "steady_state_start_s": "s"}  # attributes that become variables
    ds = ds.assign({k: ((), ds.attrs.pop(k), {"units": u}) for k, u in per_scenario.items()} | {"trace_source": ((), source)})
    del ds.attrs["scenario"]
    parts.append(ds.expand_dims(scenario=[name]))
out = xr.concat(parts, "scenario", combine_attrs="override")
out.attrs.update({"product": STREAM, "title": "Susi et al. 2014: smallest discriminator jitter per scenario (Kolmogorov-Szego, Wiener, best third-order loop)"})
out.attrs.update(provenance(config=run, seed=seed, inputs=list(sm.input)))
write_netcdf(out, sm.output[0])
