"""Rule entry point: the achievability floors of the Table III cells, one result per cell (scintrack.experiments.floors)."""

from scintrack import jobcode
from scintrack.experiments.floors import floors_table
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "vv_floors")
lut = open_dataset(sm.input.lut)
for run, output in zip(sm.params.runs.values(), sm.output, strict=True):
    fl = run["floors"]
    ds = floors_table(
        lut, [(run["s4"], run["tau0"])], tracking=run["tracking"], seed=int(run["seed"]), ts=float(run["ts"]),
        duration_s=float(fl["duration_s"]), realisations=int(fl["realisations"]), groups=int(fl["groups"]), nspa=int(run["nspa"]),
        warmup_s=float(run["warmup_s"]), stride=int(fl["stride"]), progress=log.info,
    )
    ds = ds.assign_coords(scenario=[run["scenario"]])
    ds.attrs.update({"scenario": run["scenario"], "s4": run["s4"], "tau0": run["tau0"], "cn0_dbhz": float(run["tracking"]["cn0_dbhz"]),
                     "q_jerk_hz2_s3": float(run["tracking"]["q_jerk_hz2_s3"]), "realisations": int(fl["realisations"])})
    ds.attrs.update(provenance(config=run, seed=int(run["seed"]), inputs=[sm.input.lut]))
    write_netcdf(ds, output)
    log.info("floors of %s: %s", run["scenario"], ds["rmse"].values.round(3).tolist())
