"""AR rule entry point: merge per-S4 fits into the AR look-up table."""

from scintrack import jobcode
from scintrack.io import open_dataset, provenance, write_netcdf
from scintrack.models.lut import merge_lut

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "ar_lut")
fits = [open_dataset(p) for p in sm.input]
lut = merge_lut(fits)
lut.attrs.update(provenance(config=sm.params.lut, inputs=sm.input))
lut.attrs["ts"] = fits[0].attrs["ts"]
lut.attrs["title"] = "AR scintillation look-up table (CSM, Vila-Valls 2018 Sec. III)"
write_netcdf(lut, sm.output[0])
log.info("look-up table over %d S4 x %d tau0", lut.sizes["s4"], lut.sizes["tau0"])
