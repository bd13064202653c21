"""Zhao et al.: the pre-declared readings of where the position spread comes from (docs/REPRODUCTION.md).

Each reading (``zhao_readings.readings``) is the receiver of
``zhao_receiver`` with its overrides (``receiver``, merged key by key as
configuration overlays are), run on the jammed dataset, or, with
``scenario: clean``, on the same dataset with the jammer off for the whole
scenario (the paper ran its clean statistics from a separate clean run).
The channels and positions are computed by the receiver's own functions
(:mod:`.gps_channel_result`, :mod:`.gps_positioning`); this module holds the
configuration of a reading and the pre-declared criterion.

Criterion (declared before the runs).  A reading *explains* the paper's
spread when each of the six ENU standard deviations (clean and jammed) is
within a factor 1.5 of the paper's (13/23/50 m clean, 16/32/63 m jammed)
**and** the jammed/clean ratio of each axis lies in 1.0-1.6; it *explains
part* when only one of the two conditions holds; otherwise it does not.
The conditions are tested on the means over trials of each trial's
standard deviation (the statistic the paper's single run gives).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..yamlio import deep_merge

#: Jammer onset of the clean scenario (s): after any receive time of the scenario, i.e. the jammer never starts.
CLEAN_ONSET_S = 1.0e9
#: The paper's ENU standard deviations (m): clean (PLL-aided DLL) and jammed (MM-aided DLL), east/north/up.
PAPER_STD = {"clean": (13.0, 23.0, 50.0), "jammed": (16.0, 32.0, 63.0)}
#: Pre-declared tolerances: a std within this factor of the paper's, a jammed/clean ratio in this range.
STD_FACTOR = 1.5
RATIO_RANGE = (1.0, 1.6)
#: Our trackers standing for the paper's clean and jammed solutions.
PAPER_TRACKER = {"clean": "pll", "jammed": "mm_iode"}


def clean_scenario_config(config: Mapping[str, Any]) -> dict[str, Any]:
    """The configuration of the clean scenario: ``gps_jamming`` with the jammer onset after the scenario's end."""
    out = copy.deepcopy(dict(config))
    out["gps_jamming"]["jammer"]["onset_s"] = CLEAN_ONSET_S
    return out


def reading_spec(config: Mapping[str, Any], reading: str) -> dict[str, Any]:
    """The settings of one reading, checked: receiver overrides of known keys, a ``jammed_from`` that exists."""
    zr = config["zhao_readings"]
    readings = zr["readings"]
    if reading not in readings:
        raise ConfigError(f"zhao_readings.readings: no reading {reading!r}; the readings are {', '.join(readings)}")
    spec = dict(readings[reading] or {})
    rc = config["zhao_receiver"]
    over = dict(spec.get("receiver") or {})
    known = set(rc) | {"code_phase"}
    for key, value in over.items():
        if key not in known or key in ("trials", "trial_batch", "variants", "cn0_sweep"):
            raise ConfigError(f"zhao_readings.readings.{reading}.receiver.{key}: not a receiver setting a reading may change; "
                             f"use one of {', '.join(sorted(known - {'trials', 'trial_batch', 'variants', 'cn0_sweep'}))}")
        if key == "dll":
            extra = set(value) - set(rc["dll"]) - {"carrier_aiding"}
            if extra:
                raise ConfigError(f"zhao_readings.readings.{reading}.receiver.dll.{sorted(extra)[0]}: not a DLL setting; "
                                 f"use one of {', '.join(sorted(set(rc['dll']) | {'carrier_aiding'}))}")
    scenario = spec.get("scenario", "jammed")
    source = spec.get("jammed_from")
    if source is not None and (scenario != "clean" or source not in readings or readings[source].get("scenario", "jammed") != "jammed"):
        raise ConfigError(f"zhao_readings.readings.{reading}.jammed_from: {source!r} must name a jammed-scenario reading, "
                         "and only a clean-scenario reading takes one")
    if scenario == "clean" and source is None:
        raise ConfigError(f"zhao_readings.readings.{reading}: a clean-scenario reading needs jammed_from (the reading its jammed statistics come from)")
    return {"receiver": over, "scenario": scenario, "jammed_from": source}


def reading_receiver(config: Mapping[str, Any], reading: str) -> dict[str, Any]:
    """``zhao_receiver`` with the reading's overrides, its trial count and MM variants.

    A clean-scenario reading runs the MM filter without bit priors (``mm_none``): its statistics are the
    PLL's (the paper's clean receiver), and the bit prediction belongs to the jammed dataset.
    """
    spec = reading_spec(config, reading)
    zr = config["zhao_readings"]
    # pll_lock (the pll_fll variant) is not part of the declared readings: left out
    rc = deep_merge({k: v for k, v in config["zhao_receiver"].items() if k not in ("trial_batch", "cn0_sweep", "pll_lock")}, spec["receiver"])
    rc["trials"] = int(zr["trials"])
    rc["variants"] = ["mm_none"] if spec["scenario"] == "clean" else list(zr["variants"])
    rc["figure_trial"] = min(int(rc["figure_trial"]), rc["trials"] - 1)
    return rc


def ratio_ok(ratio: np.ndarray) -> bool:
    return bool(np.all((ratio >= RATIO_RANGE[0]) & (ratio <= RATIO_RANGE[1])))


def std_ok(clean: np.ndarray, jammed: np.ndarray) -> bool:
    ours = np.concatenate([clean, jammed])
    paper = np.array([*PAPER_STD["clean"], *PAPER_STD["jammed"]])
    return bool(np.all((ours <= STD_FACTOR * paper) & (ours >= paper / STD_FACTOR)))


def verdict(clean: np.ndarray, jammed: np.ndarray) -> str:
    """The pre-declared verdict of one reading from its mean ENU stds (east, north, up), clean and jammed."""
    clean, jammed = np.asarray(clean, float), np.asarray(jammed, float)
    s, r = std_ok(clean, jammed), ratio_ok(jammed / clean)
    if s and r:
        return "explains"
    if s or r:
        return "explains part (" + ("standard deviations" if s else "ratios") + " only)"
    return "does not explain"
