"""Result rule entry point: acquisition of one raw-sample recording, a real capture or a synthetic segment.

The recording is read by :func:`scintrack.signals.recording.read_recording`
(sidecar, size and sha256 checked) and searched by
:func:`scintrack.signals.gps.acquisition.search` with the settings of
``real_signals`` (params :func:`scintrack.pipeline.params.real_acquisition`).
Beside the per-PRN result (the columns of ``acquisition_table``) the file holds
``bin_statistic``: for every PRN and Doppler bin, the largest normalised
statistic over the code phases of that bin, which is ``search`` run on that
one bin (each bin's noise is estimated from its own cells, so the value is the
same as inside the full search, and its maximum over the bins is the PRN's
``statistic``).  The figures draw the search from it without searching again.
"""

import numpy as np
import xarray as xr

from scintrack import jobcode
from scintrack.errors import InputError
from scintrack.io import provenance, write_netcdf
from scintrack.pipeline.paths import SYNTHETIC_SEGMENTS
from scintrack.signals.gps.acquisition import TABLE_COLUMNS, doppler_bins, search
from scintrack.signals.recording import read_recording

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "real_acquisition")
params = dict(sm.params.acquisition)
name, settings = params["recording"], dict(params["acquisition"])
key = "real_signals.synthetic" if name in SYNTHETIC_SEGMENTS else f"real_signals.recordings.{name}"
samples, meta = read_recording(sm.input.data)
fs, f_if = float(meta["sample_rate_hz"]), float(meta["intermediate_frequency_hz"])
t_ms, k = int(settings["n_coherent_ms"]), int(settings["n_blocks"])
length_ms = samples.size / fs * 1e3
if t_ms * k > length_ms + 1e-9:
    raise InputError(f"{key}: n_coherent_ms x n_blocks = {t_ms} x {k} ms does not fit in {sm.input.data} ({length_ms:g} ms); "
                     "shorten the coherent block or use fewer blocks (real_signals.acquisition sets the defaults)")
prns = [int(p) for p in settings["prns"]]
bins = doppler_bins(float(settings["doppler_span_hz"]), None, t_ms)
options = {"intermediate_frequency_hz": f_if, "p_fa": float(settings["p_fa"])}
found = search(samples, fs, prns, bins, t_ms, k, **options)
log.info("%s: %d PRNs x %d Doppler bins; detected %s", name, len(prns), bins.size, [a.prn for a in found if a.detected])
per_bin = np.array([[a.statistic for a in search(samples, fs, prns, [f], t_ms, k, **options)] for f in bins]).T  # (prn, doppler)

ds = xr.Dataset(coords={"prn": ("prn", np.array(prns), {"long_name": "GPS PRN searched"}),
                        "doppler": ("doppler", bins, {"long_name": "Doppler bin, relative to the intermediate frequency", "units": "Hz"})})
for column, text in TABLE_COLUMNS.items():
    if column in ("prn", "threshold"):
        continue
    ds[column] = ("prn", np.array([getattr(a, column) for a in found]), {"long_name": text})
ds["noise_power"] = ("prn", np.array([a.noise_power for a in found]), {"long_name": "estimated noise power of a cell in the peak's Doppler bin"})
ds["threshold"] = ((), float(found[0].threshold), {"long_name": TABLE_COLUMNS["threshold"]})
ds["bin_statistic"] = (("prn", "doppler"), per_bin, {"long_name": "largest normalised statistic over the code phases of each Doppler bin"})
synthetic = name in SYNTHETIC_SEGMENTS
if synthetic:  # the synthesiser's truth: the C/N0 each satellite has in the segment (after the jammer's onset if jammed)
    truth = {int(s["prn"]): float(s.get("effective_cn0_dbhz_after_onset", s["cn0_dbhz"]) if meta.get("jammer") else s["cn0_dbhz"])
             for s in meta["satellites"]}
    ds["true_cn0_dbhz"] = ("prn", np.array([truth.get(p, np.nan) for p in prns]),
                           {"long_name": "C/N0 the synthetic recording was made with (NaN: PRN not in it)", "units": "dB-Hz"})
ds.attrs.update({
    "recording": name, "data_kind": "synthetic SKYDEL-like" if synthetic else "real", "data_file": str(meta.get("data_file", "")),
    "source": str(meta["source"]), "start_time": str(meta["start_time"]), "time_scale": str(meta["time_scale"]),
    "format": str(meta["format"]), "sample_rate_hz": fs, "intermediate_frequency_hz": f_if, "duration_s": samples.size / fs,
    "n_coherent_ms": t_ms, "n_blocks": int(found[0].n_blocks), "n_cells": int(found[0].n_cells), "p_fa": float(found[0].p_fa),
    "doppler_span_hz": float(settings["doppler_span_hz"]), "doppler_step_hz": float(np.diff(bins)[0]) if bins.size > 1 else 0.0,
})
ds.attrs.update(provenance(config=params, inputs=[sm.input.data, sm.input.sidecar]))
digest = write_netcdf(ds, sm.output[0])
log.info("wrote %s (content sha256 %s)", sm.output[0], digest)
