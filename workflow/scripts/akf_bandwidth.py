"""Susi 2014 rule entry point: the AKF PLL's steady-state loop bandwidth per Q term (oscillator, q_jerk, both).

Writes ``results/susi_2014/akf_qjerk_bandwidth.nc`` for every ``susi_akf`` tracker of the ``susi_akf_qjerk``
experiment on each of its scenarios (:func:`scintrack.experiments.susi_akf_bandwidth.bandwidth_decomposition`).
"""

from scintrack import jobcode
from scintrack.experiments.susi_akf_bandwidth import bandwidth_decomposition
from scintrack.io import provenance, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "susi_akf_bandwidth")
run = sm.params.run
out = bandwidth_decomposition(run)
for sc in out["scenario"].values:
    for tr in out["tracker"].values:
        b = out["bandwidth_hz"].sel(scenario=sc, tracker=tr).values
        log.info("%s %s (q_jerk %g): both %.3f Hz, oscillator %.3f Hz, q_jerk %.3f Hz", sc, tr, float(out["q_jerk_hz2_s3"].sel(tracker=tr)), *b)
out.attrs.update(provenance(config=run))
write_netcdf(out, sm.output[0])
