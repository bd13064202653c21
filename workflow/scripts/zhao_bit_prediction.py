"""Result rule entry point: the upload-robust bit prediction of every satellite of the jammed dataset."""

from scintrack import jobcode
from scintrack.experiments.gps_bit_prediction import predictions
from scintrack.io import open_dataset, provenance, write_netcdf
from scintrack.signals.gps import ephemeris

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "zhao_bit_prediction")
params = dict(sm.params.prediction)
ds = open_dataset(sm.input.dataset)
out = predictions(ds, ephemeris.load(sm.input.ephemerides), ephemeris.read_header(sm.input.ephemerides))
out.attrs.update(provenance(config=params, inputs=[sm.input.dataset]))
digest = write_netcdf(out, sm.output[0])
log.info("wrote %s (content sha256 %s)", sm.output[0], digest)
