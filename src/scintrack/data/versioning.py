"""Dataset versions derived from the generator's code and parameters.

A dataset's version is not chosen by hand: it is a short hash of the
generator's name, its code version and every parameter (seed included).  The
code version (:func:`code_version`) is the generator's label plus
:func:`scintrack.codeversion.code_version` of the dataset module, i.e. a hash
of the normalised source (AST without comments or docstrings) of every
``scintrack`` module that module imports, the same mechanism the Snakemake
rules use for their ``code`` param.  So changing what the generator computes,
or any parameter, gives a new version, hence a new file path
``data/synthetic/<name>/<version>.nc``; old versions stay where they were and
stay addressable by their path; a comment or a docstring changes nothing.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .. import codeversion
from ..io import hash_object


def code_version(label: str, module: str) -> str:
    """``<label>-<12 hex of the normalised import closure of ``module``>``."""
    return f"{label}-{codeversion.code_version([module], length=12)}"


def dataset_version(generator: str, generator_version: str, params: Mapping[str, Any]) -> str:
    digest = hash_object({"generator": generator, "generator_version": generator_version, "params": dict(params)})
    return "v" + digest[:12]
