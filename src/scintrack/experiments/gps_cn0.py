"""C/N0 of the jammed GPS scenario estimated from correlator outputs (Zhao et al., Figs. 5 and 8).

A standard estimator on what a locked receiver sees: the correlator-level
model (:mod:`scintrack.signals.gps.correlator`) with the replica equal to the
truth (open loop, no tracking error), prompts summed coherently over
``coherent_ms`` code periods aligned with the data-bit edges, and the M2M4
moments estimator (:mod:`scintrack.estimators.cn0`) over ``window_s``
windows.  M2M4 uses |P|^2 only, so it needs neither carrier lock nor data
wipe-off; its bias at low SNR over a window of N samples is the only
difference from the truth, which the figures show side by side.  A window
where the moments give no signal power (``2 m2^2 < m4``, which happens at
15 dB-Hz over short windows) is stored as NaN ("no estimate"), not as the
estimator's floor.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from ..estimators.cn0 import M2M4_FLOOR, cn0_from_powers, m2m4, to_dbhz
from ..signals.gps.correlator import NoiseStream, open_loop

STREAM = "zhao_jamming/cn0_estimates"


def coherent_prompts(epl: np.ndarray, first_in_bit: int, coherent_ms: int) -> np.ndarray:
    """Complex prompts summed over ``coherent_ms`` code periods starting at the first bit edge; shape (blocks,)."""
    p = epl[..., 1] + 1j * epl[..., 4]
    start = (20 - first_in_bit) % 20
    n = (len(p) - start) // coherent_ms
    return p[start : start + n * coherent_ms].reshape(n, coherent_ms).sum(axis=1)


def estimate(ds: xr.Dataset, params: Mapping[str, Any]) -> xr.Dataset:
    coherent = int(params["coherent_ms"])
    per_window = int(round(float(params["window_s"]) / (coherent * 1e-3)))
    stream = NoiseStream(int(params["seed"]), STREAM, float(params["spacing_chips"]))
    t_ms = float(ds.attrs["code_period_s"])
    est, true, times = [], [], None
    for k in range(ds.sizes["sv"]):
        cn0 = ds["cn0"].isel(sv=k).values.astype(float)
        epl = open_loop(stream, [0], k, 0, cn0, ds["bit"].isel(sv=k).values, t_ms)[0]
        first = int(ds["first_epoch_in_bit"].isel(sv=k))
        prompts = coherent_prompts(epl, first, coherent)
        n_win = len(prompts) // per_window
        windows = prompts[: n_win * per_window].reshape(n_win, per_window)
        # coherent sums of k unit-variance epochs have noise variance 2k and amplitude k a: C/N0 = Pd / (Pn T_coh)
        pd, pn = m2m4(windows, axis=1)
        floored = pd <= M2M4_FLOOR * (pd + pn) * (1 + 1e-9)  # 2 m2^2 < m4: no signal-power estimate in this window
        est.append(np.where(floored, np.nan, to_dbhz(cn0_from_powers(pd, pn, coherent * t_ms))))
        start = (20 - first) % 20
        cn0_w = cn0[start : start + n_win * per_window * coherent].reshape(n_win, -1)
        true.append(to_dbhz(np.mean(10 ** (cn0_w / 10), axis=1)))
        rt = ds["receive_time"].isel(sv=k).values[start : start + n_win * per_window * coherent].reshape(n_win, -1)
        times = rt.mean(axis=1) if times is None else times
    out = xr.Dataset(
        {
            "cn0_est": (("sv", "window"), np.array(est), {"long_name": "C/N0 estimated (M2M4 on coherent prompts; NaN: no estimate)", "units": "dB-Hz"}),
            "cn0_true": (("sv", "window"), np.array(true), {"long_name": "true C/N0 (window mean)", "units": "dB-Hz"}),
        },
        coords={"prn": ("sv", ds["prn"].values), "time": ("window", times, {"long_name": "window centre, receiver time", "units": "s"})},
    )
    out.attrs.update(
        window_s=float(params["window_s"]), coherent_ms=coherent, spacing_chips=float(params["spacing_chips"]),
        estimator="M2M4", jammer_onset_s=float(ds.attrs["jammer_onset_s"]), cn0_jammed_dbhz=float(ds.attrs["cn0_jammed_dbhz"]),
        cn0_clean_dbhz=float(ds.attrs["cn0_clean_dbhz"]), dataset_version=str(ds.attrs["dataset_version"]), source="synthetic",
    )
    return out
