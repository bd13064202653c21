"""Analysis rule entry point: spectra and PACF behind Figs. 1-4."""

import xarray as xr

from scintrack import jobcode
from scintrack.io import open_dataset, provenance, write_netcdf
from scintrack.models.diagnostics import ar_diagnostics

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "ar_diagnostics")
# Only the fits of the S4 values shown: a figure never waits for the whole grid.
fits = xr.concat([open_dataset(p) for p in sm.input.fits], dim="s4")
trains = {float(ds["s4"]): ds for ds in map(open_dataset, sm.input.train)}
parts = []
run = sm.params.diag
for case, point in run["cases"].items():
    parts.append(
        ar_diagnostics(
            trains[float(point["s4"])], fits, s4=point["s4"], tau0=point["tau0"], trial=0,
            orders=run["orders"], nperseg=run["nperseg"], case=case,
        )
    )
diag = xr.concat(parts, dim="case")
diag.attrs.update(provenance(config=run, inputs=list(sm.input)))
diag.attrs["ts"] = float(next(iter(trains.values())).attrs["ts"])
diag.attrs["title"] = "AR model diagnostics of CSM amplitude and phase (trial 0)"
write_netcdf(diag, sm.output[0])
