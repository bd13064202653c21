"""Experiment rule entry point: one shard of a tracking Monte Carlo.

Everything comes from ``params.run`` (scintrack.pipeline.params.experiment
plus the shard's trials); the result records the hash of exactly those values.
"""

from scintrack import runlog
from scintrack.experiments.runner import run_shard
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], "tracking_shard")
run = sm.params.run
lut = open_dataset(sm.input.lut)
ds = run_shard(
    scenario_name=run["scenario_name"],
    scenario=run["scenario"],
    tracker_names=list(run["tracker_names"]),
    tracker_specs=run["trackers"],
    tracking=run["tracking"],
    lut=lut,
    seed=int(run["seed"]),
    ts=float(run["ts"]),
    nspa=int(run["nspa"]),
    warmup_s=float(run["warmup_s"]),
    trials=list(run["trials"]),
)
tracking = run["tracking"]
ds.attrs.update(
    {
        "cn0_dbhz": float(run["scenario"].get("cn0_dbhz", tracking["cn0_dbhz"])),
        "fd0_hz": float(tracking["fd0_hz"]),
        "fr_hz_s": float(tracking["fr_hz_s"]),
        "ts": float(run["ts"]),
    }
)
ds.attrs.update(provenance(config=run, seed=int(run["seed"]), inputs=list(sm.input), extra={"experiment": run["experiment"]}))
write_netcdf(ds, sm.output[0])
log.info("%s/%s: trials %s..%s", run["experiment"], run["scenario_name"], run["trials"][0], run["trials"][-1])
