"""Synthetic datasets written by the data rules (CSM training sets).

A training dataset holds CSM amplitude and unwrapped phase for one S4 value
over a list of tau0 values and trials, dims (tau0, trial, time), float32 on
disk (phase resolution better than 1e-5 rad for the ranges seen).

Its parameters, name and version are defined in :mod:`.synthetic_spec` (no
numerical imports: the workflow needs them to build the DAG) and re-exported
here.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from ..signals.csm import generate_csm
from .synthetic_spec import (  # noqa: F401  (the dataset's definition lives in synthetic_spec; re-exported here)
    GENERATOR,
    GENERATOR_VERSION,
    csm_training_name,
    csm_training_params,
    csm_training_version,
)


def stream_name(s4: float, tau0: float) -> str:
    """Seed-stream name of one grid point (independent streams per point)."""
    return f"csm_train/s4={s4:g}/tau0={tau0:g}"


def csm_training_dataset(params: Mapping[str, Any]) -> xr.Dataset:
    """Generate the training dataset described by ``params``."""
    ts = params["ts"]
    n_epochs = int(round(params["duration_s"] / ts))
    warmup = int(round(params["warmup_s"] / ts))
    trials = list(range(params["trials"]))
    amp, phase = [], []
    for tau0 in params["tau0"]:
        real = generate_csm(
            seed=params["seed"], name=stream_name(params["s4"], tau0), trials=trials,
            n_epochs=n_epochs, ts=ts, s4=params["s4"], tau0=tau0,
            nspa=params["nspa"], warmup=warmup, output=params["output"],
        )
        amp.append(real.rho.astype(np.float32))
        phase.append(real.theta.astype(np.float32))
    name = csm_training_name(params["s4"])
    ds = xr.Dataset(
        {
            "amplitude": (("tau0", "trial", "time"), np.array(amp), {"long_name": "scintillation amplitude rho_s = |z|", "units": "1"}),
            "phase": (("tau0", "trial", "time"), np.array(phase), {"long_name": "scintillation phase theta_s = unwrap(angle(z))", "units": "rad"}),
        },
        coords={
            "tau0": ("tau0", np.asarray(params["tau0"]), {"long_name": "decorrelation time tau0", "units": "s"}),
            "trial": ("trial", np.asarray(trials)),
            "time": ("time", np.arange(n_epochs) * ts, {"long_name": "time", "units": "s"}),
            "s4": ((), params["s4"], {"long_name": "target amplitude scintillation index S4", "units": "1"}),
        },
    )
    ds.attrs.update(
        {
            "title": f"Cornell Scintillation Model training set, S4={params['s4']:g}",
            "dataset_name": name,
            "dataset_version": csm_training_version(params),
            "generator": GENERATOR,
            "generator_version": GENERATOR_VERSION,
            "source": "synthetic (Cornell Scintillation Model, Humphreys et al. 2009)",
            "ts": ts,
        }
    )
    return ds
