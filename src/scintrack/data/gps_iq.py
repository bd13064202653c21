"""SKYDEL-like IQ recordings of the jammed GPS scenario: a clean and a jammed segment.

The paper's SKYDEL run was recorded as complex baseband at 12.5 MS/s; a
4-minute recording would be 12 GB, so we record two short segments of the
scenario (``gps_jamming.iq``: one before, one after the jammer onset) from the
scenario's truth (:mod:`scintrack.data.gps_jamming_spec`) with
:func:`scintrack.signals.gps.iq.synthesise`: every satellite with its real
C/A code, code phase, carrier phase, Doppler and data bits at the segment's
time, thermal noise at the configured clean C/N0, and in the jammed segment
the 8-MHz noise jammer at the configured J/S.

* The recording's sample clock is the receiver clock: ms k of a segment
  starting at ``start_s`` is receiver time ``start_s + k ms``; the truth's
  code epochs arrive at ``receive_time``, so the code phase at that instant
  is the fraction of the code period elapsed since the last arrival, and the
  carrier phase and Doppler are interpolated linearly between epochs.
* Both segments are written with one int16 scale (the jammed segment's peak
  at 0.9 full scale), so their spectra compare directly, as a fixed-gain
  front end would record them; the clean segment is then ~57 dB above the
  quantisation noise.
* Each segment draws its noise from its own seed, derived from the config
  seed and the segment name.

The workflow imports this module to build the DAG (the recordings' paths and
params), so numpy is imported inside :func:`segment_seed` only.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from .gps_jamming_spec import CODE_PERIOD_S, gps_jamming_params, gps_jamming_version
from .versioning import code_version, dataset_version

if TYPE_CHECKING:
    import xarray as xr

NAME = "gps_jamming_iq"
GENERATOR = "scintrack.data.gps_iq.record"
GENERATOR_VERSION = code_version("gps-iq", "scintrack.data.gps_iq_build")
CHIPS = 1023


def iq_params(config: Mapping[str, Any]) -> dict[str, Any]:
    """Everything the recordings depend on: the scenario (its params) and the recording settings."""
    return {"dataset": gps_jamming_params(config), "iq": dict(config["gps_jamming"]["iq"]), "seed": int(config["seed"])}


def iq_version(params: Mapping[str, Any]) -> str:
    return dataset_version(GENERATOR, GENERATOR_VERSION, params)


def segment_seed(seed: int, segment: str) -> int:
    """A 63-bit seed for one segment, split from the config seed."""
    import numpy as np

    from ..seeding import stable_key

    seq = np.random.SeedSequence(int(seed), spawn_key=(stable_key(f"{NAME}/{segment}"),))
    return int(seq.generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))


def segments(params: Mapping[str, Any]) -> dict[str, float]:
    iq = params["iq"]
    return {"clean": float(iq["clean_start_s"]), "jammed": float(iq["jammed_start_s"])}


def check_segments(params: Mapping[str, Any], ds: xr.Dataset) -> None:
    onset = float(ds.attrs["jammer_onset_s"])
    length = float(params["iq"]["length_s"])
    duration = float(ds.attrs["duration_s"])
    for name, start in segments(params).items():
        if start + length > duration - 2 * CODE_PERIOD_S:
            raise ValueError(f"gps_jamming.iq.{name}_start_s: the segment [{start:g}, {start + length:g}] s must end inside the {duration:g}-s scenario")
    if params["iq"]["clean_start_s"] + length > onset:
        raise ValueError(f"gps_jamming.iq.clean_start_s: the clean segment must end before the jammer onset ({onset:g} s)")
    if params["iq"]["jammed_start_s"] < onset:
        raise ValueError(f"gps_jamming.iq.jammed_start_s: the jammed segment must start at or after the jammer onset ({onset:g} s)")


def dataset_version_of(params: Mapping[str, Any]) -> str:
    return gps_jamming_version(params["dataset"])
