"""Result rule entry point: positions and metrics of the jamming receiver from its channels."""

from scintrack import jobcode
from scintrack.experiments.gps_positioning import receiver_result
from scintrack.io import open_dataset, provenance, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "zhao_receiver")
params = dict(sm.params.receiver)
ds = open_dataset(sm.input.dataset)
channels = [open_dataset(p) for p in sm.input.channels]
out = receiver_result(ds, channels, params)
out.attrs.update({k: str(params[k]) for k in ("reading", "scenario", "jammed_from") if k in params})  # a pre-declared reading (zhao_readings)
out.attrs.update(provenance(config=params, seed=params["seed"], inputs=[sm.input.dataset, *sm.input.channels]))
digest = write_netcdf(out, sm.output[0])
log.info("wrote %s (content sha256 %s)", sm.output[0], digest)
