"""Result rule entry point: C/N0 estimated from correlator outputs over the jammed GPS scenario."""

from scintrack import jobcode
from scintrack.experiments.gps_cn0 import estimate
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "zhao_cn0_estimates")
params = dict(sm.params.cn0)
ds = open_dataset(sm.input.dataset)
out = estimate(ds, params)
out.attrs.update(provenance(config=params, seed=params["seed"], inputs=[sm.input.dataset]))
digest = write_netcdf(out, sm.output[0])
log.info("wrote %s (content sha256 %s)", sm.output[0], digest)
