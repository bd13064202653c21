"""The project's one way to read YAML: PyYAML's safe loader on libyaml's parser.

PyYAML's ``CSafeLoader`` has the same constructor and resolver as ``SafeLoader``
(so the same values) and parses config.yaml about 10x faster; every Snakemake
start-up reads it.  Where PyYAML was built without libyaml the
pure-Python ``SafeLoader`` is used.  A module of its own, importing nothing of
the package: a reader of YAML (the dataset registry, the archive check) does not
take the config module's imports into its code version.
"""

from __future__ import annotations

from typing import Any

import yaml

SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def yaml_load(text: str | bytes) -> Any:
    """``yaml.safe_load(text)`` with :data:`SAFE_LOADER`."""
    return yaml.load(text, Loader=SAFE_LOADER)  # noqa: S506 (a safe loader)
