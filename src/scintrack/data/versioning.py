"""Dataset versions derived from the generator's code version and parameters.

A dataset's version is not chosen by hand: it is a short hash of the
generator's name, its ``GENERATOR_VERSION`` constant and every parameter
(seed included).  Changing either gives a new version, hence a new file path
``data/synthetic/<name>/<version>.nc``; old versions stay where they were.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..io import hash_object


def dataset_version(generator: str, generator_version: str, params: Mapping[str, Any]) -> str:
    digest = hash_object({"generator": generator, "generator_version": generator_version, "params": dict(params)})
    return "v" + digest[:12]
