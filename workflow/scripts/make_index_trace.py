"""Data rule entry point: the SURROGATE trace of the real-index event (Susi 2014, high latitude).

Chooses the pre-declared event from the real BiScEF index rows
(:func:`scintrack.data.biscef.strongest_run`) and makes its trace
(:func:`scintrack.data.index_trace.index_trace`).
"""

import xarray as xr

from scintrack import jobcode
from scintrack.data.biscef import strongest_run
from scintrack.data.index_trace import GENERATOR, index_trace
from scintrack.errors import InputError
from scintrack.io import provenance, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "susi_index_trace")
params = dict(sm.params.dataset)
with xr.open_dataset(sm.input.indices) as rows:
    rows = rows.load()
run = strongest_run(rows, int(params["minutes"]), float(params["cn0_min_dbhz"]))
log.info("event: %s PRN %d from %s UTC, %d minutes, median Phi60 %.3f rad, C/N0 >= %.1f dB-Hz", run["station_name"], run["prn"],
         run["start_utc"], run["minutes"], run["median_phi60"], min(run["cn0"]))
try:
    ds = index_trace(params, run)
except ValueError as exc:
    raise InputError(f"susi_2014.traces.{params['name']}: {exc}") from None
ds.attrs.update({"dataset_name": f"susi_index_{params['name']}", "dataset_version": sm.wildcards.version, "generator": GENERATOR})
ds.attrs.update(provenance(config=params, seed=params["seed"], inputs=list(sm.input), extra={"params": params}))
digest = write_netcdf(ds, sm.output[0])
log.info("wrote %s: trace sigma_phi per window %s rad against the real Phi60 %s rad (content %s)", sm.output[0],
         ds["trace_phi60"].values.round(3), ds["real_phi60"].values.round(3), digest)
