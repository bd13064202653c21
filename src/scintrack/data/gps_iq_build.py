"""Synthesise the IQ segments of :mod:`scintrack.data.gps_iq` from the scenario's truth."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from ..signals.gps import iq
from .gps_iq import CHIPS, GENERATOR, GENERATOR_VERSION, NAME, check_segments, iq_version, segment_seed, segments
from .gps_jamming_spec import CODE_PERIOD_S


def sv_signal(ds: xr.Dataset, k: int, start_s: float, n_ms: int) -> iq.SvSignal:
    """Per-ms truth of satellite ``k`` for the recording's ms grid ``start_s + j ms`` (receiver clock)."""
    rt = ds["receive_time"].isel(sv=k).values
    t = start_s + CODE_PERIOD_S * np.arange(n_ms)
    n = np.searchsorted(rt, t, side="right") - 1
    if n[0] < 0 or n[-1] + 1 >= len(rt):
        raise ValueError(f"segment at {start_s:g} s lies outside the truth of PRN {int(ds['prn'][k])}")
    frac = (t - rt[n]) / (rt[n + 1] - rt[n])
    phase = ds["carrier_phase"].isel(sv=k).values
    carrier = phase[n] + frac * (phase[n + 1] - phase[n])
    doppler = ds["doppler"].isel(sv=k).values
    return iq.SvSignal(
        prn=int(ds["prn"].values[k]),
        cn0_dbhz=float(ds.attrs["cn0_clean_dbhz"]),
        code_phase_chips=CHIPS * frac,
        carrier_phase_rad=2.0 * np.pi * (carrier - np.floor(carrier[0])),
        doppler_hz=doppler[n] + frac * (doppler[n + 1] - doppler[n]),
        data_bits=ds["bit"].isel(sv=k).values[n].astype(float),
    )


def record(ds: xr.Dataset, params: Mapping[str, Any]) -> dict[str, tuple[np.ndarray, dict]]:
    """{segment: (complex samples, sidecar)} for the clean and the jammed segment (not yet quantised)."""
    check_segments(params, ds)
    fs = float(params["iq"]["sample_rate_hz"])
    length = float(params["iq"]["length_s"])
    n_ms = int(round(length / CODE_PERIOD_S))
    onset = float(ds.attrs["jammer_onset_s"])
    out = {}
    for name, start in segments(params).items():
        svs = [sv_signal(ds, k, start, n_ms) for k in range(ds.sizes["sv"])]
        jammer = None
        if start + length > onset:
            jammer = iq.Jammer(float(ds.attrs["jammer_js_db"]), float(ds.attrs["jammer_bandwidth_hz"]), float(ds.attrs["jammer_offset_hz"]),
                               onset_s=max(0.0, onset - start))
        seed = segment_seed(params["seed"], name)
        samples = iq.synthesise(svs, fs, duration_s=length, seed=seed, jammer=jammer)
        sidecar = iq.make_sidecar(svs, fs=fs, duration_s=length, seed=seed, gps_week=int(ds.attrs["gps_week"]),
                                  gps_seconds_of_week=float(ds.attrs["t_start_sow"]) + start, jammer=jammer)
        sidecar.update(
            segment=name, segment_start_s=start, dataset_name=NAME, dataset_version=iq_version(params), generator=GENERATOR,
            generator_version=GENERATOR_VERSION, source="synthetic (SKYDEL-like)", scenario_dataset=str(ds.attrs["dataset_version"]),
            params=dict(params),
        )
        out[name] = (samples, sidecar)
    return out


def common_scale(recorded: Mapping[str, tuple[np.ndarray, dict]], peak_fraction: float = iq.DEFAULT_PEAK_FRACTION) -> float:
    """One int16 scale for every segment: the largest |I| or |Q| of any of them -> ``peak_fraction`` of full scale."""
    peak = max(float(np.max(np.abs(s.view(np.float32)))) for s, _ in recorded.values())
    return peak_fraction * iq.FULL_SCALE / peak


def write(recorded: Mapping[str, tuple[np.ndarray, dict]], targets: Mapping[str, str]) -> dict[str, dict]:
    scale = common_scale(recorded)
    written = {}
    for name, (samples, sidecar) in recorded.items():
        written[name] = iq.write_recording(targets[name], samples, sidecar, scale=scale)
    return written

