"""Result rule entry point: one point of the jammed-C/N0 sweep of the jamming receiver."""

from scintrack import jobcode
from scintrack.experiments.gps_positioning import sweep_point
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, f"zhao_cn0_sweep {sm.wildcards.cn0}")
params = dict(sm.params.receiver)
ds = open_dataset(sm.input.dataset)
out = sweep_point(ds, params, float(sm.wildcards.cn0), sm.input.ephemerides, trial_batch=int(sm.resources.trial_batch),
                  prediction=open_dataset(sm.input.prediction))
out.attrs.update(provenance(config=params, seed=params["seed"], inputs=[sm.input.dataset]))
digest = write_netcdf(out, sm.output[0])
log.info("wrote %s (content sha256 %s)", sm.output[0], digest)
