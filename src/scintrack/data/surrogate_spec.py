"""What defines a surrogate scintillation event: its parameters and version.

The config-shaping half of :mod:`scintrack.data.surrogate`, without numpy,
xarray or the phase-screen generator: the workflow calls these functions
whenever Snakemake builds the DAG (a rule's params, a trace's path), which
must not load the numerical stack.  :mod:`.surrogate` generates
the event and re-exports everything here.

The version is :func:`.versioning.code_version` of the generator module
:mod:`scintrack.data.surrogate` (named, not imported), i.e. of the
normalised source of everything it imports, this module and the phase
screen included.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .versioning import code_version, dataset_version

GENERATOR = "scintrack.signals.phase_screen"
#: Label of the generator, bumped whenever a code change alters the generated values (the
#: code version follows the code anyway); with the code version it enters the dataset version.
LABEL = "1"
GENERATOR_VERSION = code_version(LABEL, "scintrack.data.surrogate")


def surrogate_params(config: Mapping[str, Any], event: str) -> dict[str, Any]:
    rt = config["real_traces"]
    sur = rt["surrogate"]
    ev = sur["events"][event]
    return {
        "seed": int(config["seed"]),
        "event": event,
        "ts": float(config["sampling"]["ts"]),
        "bands": list(rt["bands"]),
        "duration_s": float(rt["fit_s"]) + float(rt["eval_s"]),
        "s4_l1": float(ev["s4_l1"]),
        "sigma_phi_l1": float(ev["sigma_phi_l1"]),
        "profile": [[float(a), float(b)] for a, b in ev["profile"]],
        "height_m": float(sur["height_m"]),
        "drift_m_s": float(ev.get("drift_m_s", sur["drift_m_s"])),
        "outer_scale_m": float(sur["outer_scale_m"]),
        "window_s": float(sur["window_s"]),
        "detrend_hz": float(sur["detrend_hz"]),
    }


def surrogate_version(params: Mapping[str, Any]) -> str:
    return dataset_version(GENERATOR, GENERATOR_VERSION, params)
