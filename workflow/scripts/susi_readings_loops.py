"""Susi 2014 rule entry point: the steady-state loop of each reading U1-U4 of eqs. (7)-(8).

Writes ``results/susi_2014/readings_loops.nc``: for every Susi KF tracker of the ``susi_readings`` experiment on
each of its scenarios, the median on-line T, p and weight of its run and the noise bandwidth of its Riccati gain
there (:func:`scintrack.experiments.susi_readings.readings_loops`).
"""

from scintrack import jobcode
from scintrack.experiments.susi_readings import readings_loops
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "susi_readings_loops")
run = sm.params.run
results = {sc: open_dataset(sm.input[f"result_{sc}"]) for sc in run["scenarios"]}
out = readings_loops(run, results)
for sc in out["scenario"].values:
    for tr in out["tracker"].values:
        r = out.sel(scenario=sc, tracker=tr)
        log.info("%s %s (%s): T %.4g, p %.3f, w %.3f -> S_dphi %.4g rad^2/s, S_df %.4g Hz^2/s, loop %.2f Hz (weighted %.2f Hz)", sc, tr,
                 str(r["reading"].values), float(r["T_median"]), float(r["p_median"]), float(r["weight_median"]), float(r["s_phi"]), float(r["s_f"]),
                 float(r["bandwidth_hz"]), float(r["bandwidth_weighted_hz"]))
out.attrs.update({"product": "susi_readings_loops", "experiment": run["experiment"],
                  "title": "Susi et al. 2014: steady-state loop bandwidth of each reading of eqs. (7)-(8) at its median on-line T, p"})
out.attrs.update(provenance(config=run, inputs=list(sm.input)))
write_netcdf(out, sm.output[0])
