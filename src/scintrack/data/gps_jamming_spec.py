"""The jammed SKYDEL-like GPS L1 C/A scenario (Zhao, Khanafseh & Pervan): truth per satellite and code epoch.

What the paper's SKYDEL run contained, generated from first principles
(docs/gps-jamming.md): a static receiver, four satellites on real broadcast
ephemerides, 4 minutes, clean at ~46 dB-Hz, then an 8-MHz noise jammer.
The dataset is the *truth* a correlator-level simulation (or a receiver
test) needs, one row per satellite and C/A code period:

* the epoch grid of each satellite is its own code periods (satellite time
  ``t_sv = T0 + n * 1 ms``), so that data-bit edges fall on epoch boundaries
  (20 code periods per bit) exactly as a receiver integrating code period by
  code period sees them; ``receive_time`` is when that code epoch arrives,
  on the receiver's clock, from the scenario start;
* ``pseudorange = c (receive clock - t_sv)``: geometric range (light time
  iterated, Earth rotation during transit) + c (receiver clock - satellite
  clock) + ionospheric + tropospheric group delays;
* ``carrier_phase`` (cycles) ``= -(pseudorange - 2 I) / lambda + phi0``: the
  ionosphere advances the carrier by what it delays the code; ``phi0`` per
  satellite is uniform in [0, 1) cycle from the seed;
* ``doppler`` (Hz) the derivative of the carrier phase with respect to the
  receiver clock: ``-(range rate + c (drift_rx - drift_sv) + d(T - I)/dt) / lambda``;
* ``cn0`` (dB-Hz): the configured clean value, and after the onset the
  effective C/N0 of :func:`scintrack.signals.gps.jamming.effective_cn0_dbhz`
  from the J/S and the computed spectral separation coefficient;
* ``bit``: the transmitted LNAV level (+1 for bit 0, -1 for bit 1) during
  the code period, from :mod:`scintrack.signals.gps.message`;
* the navigation message itself (bits from ``message_lead_s`` before the
  start, the receiver's history) and its data-set history per subframe
  (IODC, IODE copies, t_oe, regular or upload), and the geometry at 1 s
  (azimuth, elevation, range, DOP).

The receiver clock is one realisation of the configured oscillator
(:mod:`scintrack.models.clock`) started at zero offset and zero frequency
error; the truth orbit of each satellite is the broadcast data set nearest
the window's middle (the one a receiver decodes may be another: broadcast
ephemeris error is part of the scenario, as in reality).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..project import project_file
from .registry import expected_sha256
from .versioning import code_version, dataset_version

NAME = "gps_jamming"
GENERATOR = "scintrack.data.gps_jamming.gps_jamming_dataset"
GENERATOR_VERSION = code_version("gps-jamming", "scintrack.data.gps_jamming_build")

C = 299792458.0
F_L1 = 1575.42e6
LAMBDA_L1 = C / F_L1
CODE_PERIOD_S = 1e-3


def registry_name(ephemerides: str) -> str:
    """Registry entry of an ephemerides file: ``ephemerides_<file name, non-word characters as _>``."""
    return "ephemerides_" + re.sub(r"\W", "_", Path(ephemerides).name)


def gps_jamming_params(config: Mapping[str, Any]) -> dict[str, Any]:
    """Every value the dataset depends on (enters its version), including the ephemerides' sha256."""
    g = config["gps_jamming"]
    registry = project_file(config["real_traces"]["registry"])
    keys = ("ephemerides", "receiver", "prns", "duration_s", "start_utc", "window", "cn0_dbhz", "jammer", "clock", "iono", "tropo", "uploads", "message_lead_s")
    params = {key: g[key] for key in keys}
    params["prns"] = [int(p) for p in params["prns"]]
    params["seed"] = int(config["seed"])
    params["ephemerides_sha256"] = expected_sha256(registry, registry_name(g["ephemerides"]))
    return params


def gps_jamming_version(params: Mapping[str, Any]) -> str:
    return dataset_version(GENERATOR, GENERATOR_VERSION, params)
