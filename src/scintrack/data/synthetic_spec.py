"""What defines a CSM training dataset: its parameters, name and version.

The config-shaping half of :mod:`scintrack.data.synthetic`, without numpy,
xarray or the generator: the workflow calls these functions whenever
Snakemake builds the DAG (a rule's params, a dataset's path), which must not
load the numerical stack.  :mod:`.synthetic` generates the
dataset and re-exports everything here.

The version is :func:`.versioning.code_version` of the generator module
:mod:`scintrack.data.synthetic` (named, not imported), i.e. of the
normalised source of everything it imports, this module and the CSM
generator included.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .versioning import code_version, dataset_version

GENERATOR = "scintrack.signals.csm.generate_csm"
#: Label of the generator, bumped whenever a code change alters the generated values (the
#: code version follows the code anyway); with the code version it enters the dataset version,
#: so old datasets stay addressable.
LABEL = "csm-1"
GENERATOR_VERSION = code_version(LABEL, "scintrack.data.synthetic")


def csm_training_params(config: Mapping[str, Any], s4: float) -> dict[str, Any]:
    """All parameters that define one CSM training dataset (enter its version)."""
    tr = config["ar_training"]
    return {
        "seed": int(config["seed"]),
        "s4": float(s4),
        "tau0": [float(t) for t in tr["tau0"]],
        "duration_s": float(tr["duration_s"]),
        "trials": int(tr["trials"]),
        "ts": float(config["sampling"]["ts"]),
        "nspa": int(config["sampling"]["nspa"]),
        "output": config["csm"]["output"],
        "warmup_s": float(config["csm"]["warmup_s"]),
    }


def csm_training_name(s4: float) -> str:
    return f"csm_train_s4-{s4:g}"


def csm_training_version(params: Mapping[str, Any]) -> str:
    return dataset_version(GENERATOR, GENERATOR_VERSION, params)
