"""Result rule entry point: closed-loop tracking of the satellites a recording's acquisition detected.

Every detected PRN of the acquisition result is tracked by
:func:`scintrack.experiments.real_tracking.track_recording` (Costas PLL and
MM channel, carrier-aided DLL) with the loop settings of
``real_signals.tracking``.  The file holds the per-epoch outputs, the
per-satellite :func:`~scintrack.experiments.real_tracking.summary` (C/N0, lock,
bit synchronisation, phase-error spreads) and ``bit_edge``: the epochs whose
sign change the bit synchronisation counted as a data transition, found as
``summary`` finds them (the prompts after the pull-in).  A recording with no
detected satellite gives a file with an empty ``prn`` dimension.
"""

import numpy as np
import xarray as xr

from scintrack import jobcode
from scintrack.errors import InputError
from scintrack.experiments.real_tracking import TS, TrackingSettings, summary, track_recording
from scintrack.io import open_dataset, provenance, write_netcdf
from scintrack.signals.gps import bit_sync
from scintrack.signals.gps.acquisition import Acquisition
from scintrack.signals.recording import read_recording
from scintrack.trackers.mm_kf import MMKF
from scintrack.trackers.pll import PLL

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "real_tracking")
params = dict(sm.params.tracking)
name, loop = params["recording"], dict(params["tracking"])
settings = TrackingSettings(
    pll=PLL(ts=TS, bandwidth_hz=float(loop["pll_bandwidth_hz"]), discriminator="atan"),
    mm=MMKF(ts=TS, m2m4_window=int(loop["mm_m2m4_window"])),
    **{k: loop[k] for k in ("pull_in_ms", "fine_search_ms", "code_passes", "dll_bandwidth_hz", "spacing_chips", "cn0_window_ms",
                            "lock_threshold_rad", "lock_window_s")},
)
samples, meta = read_recording(sm.input.data)
fs, f_if = float(meta["sample_rate_hz"]), float(meta["intermediate_frequency_hz"])
length_ms = samples.size / fs * 1e3
need_ms = max(settings.pull_in_ms + bit_sync.BIT_MS, settings.fine_search_ms) + 2
if length_ms < need_ms:
    raise InputError(f"real_signals.tracked: {name} lasts {length_ms:g} ms, less than the {need_ms} ms that tracking needs "
                     "(real_signals.tracking.pull_in_ms + one 20-ms data bit, and fine_search_ms); remove it or shorten those settings")

acq = open_dataset(sm.input.acquisition)
fields = [f for f in Acquisition.__dataclass_fields__ if f not in ("prn", "threshold", "n_blocks", "n_cells", "p_fa")]
acquisitions = {}
for prn in acq["prn"].values[acq["detected"].values.astype(bool)]:
    one = acq.sel(prn=prn)
    acquisitions[int(prn)] = Acquisition(prn=int(prn), threshold=float(acq["threshold"]), n_blocks=int(acq.attrs["n_blocks"]),
                                         n_cells=int(acq.attrs["n_cells"]), p_fa=float(acq.attrs["p_fa"]),
                                         **{f: one[f].item() for f in fields})
log.info("%s: tracking PRN %s", name, sorted(acquisitions))

if acquisitions:
    ds = track_recording(samples, fs, acquisitions, settings, intermediate_frequency_hz=f_if)
    table = summary(ds)
    edges = np.zeros((ds.sizes["prn"], ds.sizes["epoch"]), dtype=bool)
    for i in range(ds.sizes["prn"]):  # the transitions summary() counts: sign changes after the pull-in on the bit-edge offset
        one = ds.isel(prn=i)
        after = np.flatnonzero((one["epoch"].values >= settings.pull_in_ms) & np.isfinite(one["pll_phase_error"].values))
        found = bit_sync.bit_sync(one["prompt_i"].values[after] + 1j * one["prompt_q"].values[after])
        edges[i, after[found.edges]] = True
    ds["bit_edge"] = (("prn", "epoch"), edges, {"long_name": "a data transition counted by the bit synchronisation starts at this epoch"})
    ds = ds.merge(table)
else:  # nothing detected (a jammed segment): an empty result says so
    ds = xr.Dataset(coords={"prn": ("prn", np.zeros(0, dtype=np.int64))})
ds.attrs.update({
    "recording": name, "data_kind": acq.attrs["data_kind"], "pull_in_ms": settings.pull_in_ms, "pll_bandwidth_hz": settings.pll.bandwidth_hz,
    "mm_m2m4_window": settings.mm.m2m4_window, "dll_bandwidth_hz": settings.dll_bandwidth_hz, "spacing_chips": settings.spacing_chips,
    "cn0_window_ms": settings.cn0_window_ms, "lock_threshold_rad": settings.lock_threshold_rad, "lock_window_s": settings.lock_window_s,
    "sample_rate_hz": fs, "duration_s": samples.size / fs, "n_detected": len(acquisitions),
})
ds.attrs.update(provenance(config=params, inputs=[sm.input.data, sm.input.sidecar, sm.input.acquisition]))
digest = write_netcdf(ds, sm.output[0])
log.info("wrote %s (content sha256 %s)", sm.output[0], digest)
