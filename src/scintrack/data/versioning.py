"""Dataset versions derived from the generator's code and parameters.

A dataset's version is not chosen by hand: it is a short hash of the
generator's name, its code version and every parameter (seed included).  The
code version (:func:`code_version`) is a hash of the generator's source files
plus its ``GENERATOR_VERSION`` label, so editing the generator (even a comment,
conservatively) or any parameter gives a new version, hence a new file path
``data/synthetic/<name>/<version>.nc``; old versions stay where they were and
stay addressable by their path.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from pathlib import Path
from types import ModuleType
from typing import Any

from ..io import hash_object


def code_version(label: str, *sources: ModuleType | str | Path) -> str:
    """``<label>-<sha256 of the sources (modules or file paths), 12 hex>``."""
    h = hashlib.sha256()
    for src in sources:
        h.update(Path(src.__file__ if isinstance(src, ModuleType) else src).read_bytes())
    return f"{label}-{h.hexdigest()[:12]}"


def dataset_version(generator: str, generator_version: str, params: Mapping[str, Any]) -> str:
    digest = hash_object({"generator": generator, "generator_version": generator_version, "params": dict(params)})
    return "v" + digest[:12]
