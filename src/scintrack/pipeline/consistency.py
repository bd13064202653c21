"""Was every result computed with the config being archived?

Each result records ``config_sha256``, the hash of the config values its
rule depended on (:mod:`.params`).  Given a config (the one ``archive`` packs,
or the one inside a bundle that ``verify`` reads), :func:`expected_hashes`
recomputes those hashes and :func:`mismatches` names every result whose
recorded hash differs, so a bundle can never pair a config with results of
another one.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..io import hash_object
from . import params


def expected_hashes(config: Mapping[str, Any]) -> dict[str, str]:
    """Result path -> the ``config_sha256`` it must carry under ``config``."""
    return {path: hash_object(p) for path, p in params.results(config).items()}


def mismatches(config: Mapping[str, Any], recorded: Mapping[str, str | None]) -> list[str]:
    """One line per result whose recorded config hash is not the one ``config`` gives."""
    lines = []
    for path, want in expected_hashes(config).items():
        if path not in recorded:
            continue
        got = recorded[path]
        if got != want:
            lines.append(
                f"CONFIG-DIFFERS {path} (computed with config hash {str(got)[:12]}, the archived config gives {want[:12]}): "
                "it was not computed with this configuration"
            )
    return lines
