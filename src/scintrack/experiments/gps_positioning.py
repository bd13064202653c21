"""Positions of the jamming receiver from its channels' pseudoranges, and the metrics over satellites and trials.

At each position epoch t (receiver time, ``zhao_receiver.position_rate_hz``)
every channel gives a measured pseudorange (:mod:`.gps_channel_result`); the
transmit time is ``t - rho / c`` (SV time), the satellite position and clock
come from the data set decoded before the scenario
(:func:`.gps_receiver.decoded_ephemeris`: a receiver cannot decode a new one
at 15 dB-Hz), and :func:`scintrack.navigation.position.solve` gives position
and clock by least squares.  With ``zhao_receiver.corrections`` the
channels remove the ionospheric (Klobuchar, broadcast alpha/beta) and
tropospheric model delays, which are the dataset's own delays, so the
atmosphere is perfectly modelled; without it they stay in the pseudoranges
as biases of 5-30 m in the position (measured: -5/-6.5/+28 m E/N/U).  The
paper does not say which it did; its clean means of 3.9/0.2/0.5 m suggest
corrections.  ENU errors are about the true receiver position.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from ..navigation.position import enu_errors, solve
from ..signals.gps.orbit import C_LIGHT, satellite_state
from .gps_receiver import decoded_ephemeris

METRICS = ("phase_rmse_clean", "phase_rmse_jammed", "freq_var_clean", "freq_var_jammed", "lol_events", "in_lock_jammed",
           "bit_error_clean", "bit_error_jammed", "predicted", "prediction_wrong")


def positions(ds: xr.Dataset, channels: Sequence[xr.Dataset]) -> xr.Dataset:
    """ENU errors (tracker, trial, time, axis) from the channels' pseudoranges."""
    t0 = float(ds.attrs["t_start_sow"])
    times = channels[0]["pos_time"].values
    for ch in channels[1:]:
        times = np.intersect1d(times, ch["pos_time"].values)
    trackers = list(channels[0]["tracker"].values)
    prs = np.stack([ch["pseudorange"].sel(pos_time=times).values for ch in channels], axis=-1)  # (tracker, trial, time, sv)
    sat_pos = np.empty(prs.shape + (3,))
    sat_clk = np.empty(prs.shape)
    t_rx = t0 + times
    for j, ch in enumerate(channels):
        k = int(np.flatnonzero(ds["prn"].values == ch.attrs["prn"])[0])
        eph = decoded_ephemeris(ds, k)
        t_sv = t_rx[None, None, :] - prs[..., j] / C_LIGHT
        flat = t_sv.reshape(-1)
        clk = satellite_state(eph, flat).clock_bias
        state = satellite_state(eph, flat - clk)
        sat_pos[..., j, :] = state.position.reshape(t_sv.shape + (3,))
        sat_clk[..., j] = state.clock_bias.reshape(t_sv.shape)
    rx0 = np.asarray(ds.attrs["receiver_ecef_m"], dtype=float)
    fix = solve(sat_pos, prs, sat_clk, x0=rx0 + 1000.0)
    enu = enu_errors(fix.position, float(ds.attrs["receiver_lat_deg"]), float(ds.attrs["receiver_lon_deg"]), float(ds.attrs["receiver_height_m"]))
    return xr.Dataset(
        {"enu_error": (("tracker", "trial", "time", "axis"), enu.astype(np.float32), {"units": "m"}),
         "pdop": (("tracker", "trial", "time"), np.asarray(fix.dop["pdop"], dtype=np.float32))},
        coords={"tracker": ("tracker", trackers), "trial": channels[0]["trial"].values, "time": ("time", times, {"units": "s"}), "axis": ["east", "north", "up"]},
    )


def receiver_result(ds: xr.Dataset, channels: Sequence[xr.Dataset], params: Mapping[str, Any]) -> xr.Dataset:
    pos = positions(ds, channels)
    onset = float(ds.attrs["jammer_onset_s"])
    jam = pos["time"].values >= onset
    enu = pos["enu_error"].values.astype(float)
    out = pos.copy()
    for name, sel in (("clean", ~jam), ("jammed", jam)):
        out[f"enu_mean_{name}"] = (("tracker", "trial", "axis"), enu[:, :, sel].mean(axis=2), {"units": "m"})
        out[f"enu_std_{name}"] = (("tracker", "trial", "axis"), enu[:, :, sel].std(axis=2, ddof=1), {"units": "m"})
        out[f"err3d_rms_{name}"] = (("tracker", "trial"), np.sqrt(np.mean(np.sum(enu[:, :, sel] ** 2, axis=-1), axis=2)), {"units": "m"})
    prns = [int(ch.attrs["prn"]) for ch in channels]
    for key in METRICS:
        out[f"sv_{key}"] = (("tracker", "prn", "trial"), np.stack([ch[key].values for ch in channels], axis=1))
    out = out.assign_coords(prn=("prn", prns))
    for what in ("example_phase", "example_frequency", "rmse_t"):
        out[what] = (("tracker", "prn", "time_bit"), np.stack([ch[what].values for ch in channels], axis=1))
    if "example_pll_fll_locked" in channels[0]:  # zhao_receiver.pll_lock: the pll_fll variant's own detector (figures 6, 9)
        out["example_pll_fll_locked"] = (("prn", "time_bit"), np.stack([ch["example_pll_fll_locked"].values for ch in channels]))
    out = out.assign_coords(time_bit=("time_bit", channels[0]["time"].values))
    out["prediction_last"] = channels[0]["prediction_last"]
    out["prediction_next"] = channels[0]["prediction_next"]
    uploads = {int(u["prn"]): float(u["time_s"]) for u in params["dataset"]["uploads"]}
    out.attrs.update(
        jammer_onset_s=onset, cn0_clean_dbhz=float(ds.attrs["cn0_clean_dbhz"]), cn0_jammed_dbhz=float(ds.attrs["cn0_jammed_dbhz"]),
        n_trials=int(pos.sizes["trial"]), figure_trial=int(params["receiver"]["figure_trial"]), source="synthetic",
        uploads=", ".join(f"PRN {p} at {t:g} s" for p, t in uploads.items()) or "none",
        receiver_lat_deg=float(ds.attrs["receiver_lat_deg"]), receiver_lon_deg=float(ds.attrs["receiver_lon_deg"]),
        dataset_version=str(ds.attrs["dataset_version"]), prediction_map_prn=int(channels[0].attrs["prn"]),
        lock=(f"running {float(params['receiver']['lock']['window_s']):g}-s mean of |phase error| above "
              f"{float(params['receiver']['lock']['threshold_rad']):g} rad"),
        atmosphere=("broadcast ionosphere and troposphere models applied (they cancel the dataset's delays)"
                    if params["receiver"]["corrections"] else "no atmospheric corrections"),
    )
    return out


def sweep_point(ds: xr.Dataset, params: Mapping[str, Any], cn0_dbhz: float, ephemerides_path, trial_batch: int | None = None,
                prediction: xr.Dataset | None = None) -> xr.Dataset:
    """Tracking metrics of every channel with the jammed C/N0 replaced by ``cn0_dbhz`` (``cn0_sweep.trials`` trials).

    Only the carrier-to-noise ratio after the onset changes (the jammer's J/S
    that gives it); geometry, clock, message and noise draws are the
    scenario's, so the points of the sweep differ by the C/N0 alone.  ``prediction``: the dataset's bit
    predictions (:func:`.gps_channel_result.channel_result`).
    """
    from .gps_channel_result import channel_result

    trials = int(params["receiver"]["cn0_sweep"]["trials"])
    chans = [channel_result(ds, int(p), params, ephemerides_path, cn0_jammed_dbhz=cn0_dbhz, trials=trials, trial_batch=trial_batch,
                            prediction=prediction)
             for p in ds["prn"].values]
    out = xr.Dataset({key: (("tracker", "prn", "trial"), np.stack([c[key].values for c in chans], axis=1)) for key in METRICS},
                     coords={"tracker": chans[0]["tracker"].values, "prn": [int(c.attrs["prn"]) for c in chans], "trial": np.arange(trials)})
    out.attrs.update(cn0_jammed_dbhz=float(cn0_dbhz), n_trials=trials, source="synthetic", jammer_onset_s=float(ds.attrs["jammer_onset_s"]))
    return out
