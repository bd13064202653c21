"""Experiment rule entry point: one shard of a tracking Monte Carlo."""

from scintrack import runlog
from scintrack.experiments.runner import run_shard
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], "tracking_shard")
cfg = sm.config
scenario = sm.wildcards.scenario
if scenario not in cfg["scenarios"]:
    raise SystemExit(f"experiment {sm.wildcards.experiment}: scenario {scenario!r} is not defined under 'scenarios' in the config")
lut = open_dataset(sm.input.lut)
ds = run_shard(
    scenario_name=scenario,
    scenario=cfg["scenarios"][scenario],
    tracker_names=list(sm.params.trackers),
    tracker_specs=cfg["trackers"],
    tracking=cfg["tracking"],
    lut=lut,
    seed=int(cfg["seed"]),
    ts=float(cfg["sampling"]["ts"]),
    nspa=int(cfg["sampling"]["nspa"]),
    warmup_s=float(cfg["csm"]["warmup_s"]),
    trials=list(sm.params.trials),
)
ds.attrs.update(provenance(config=cfg, seed=int(cfg["seed"]), inputs=list(sm.input), extra={"experiment": sm.wildcards.experiment}))
write_netcdf(ds, sm.output[0])
log.info("%s/%s: trials %s..%s", sm.wildcards.experiment, scenario, sm.params.trials[0], sm.params.trials[-1])
