"""The registry of external datasets (``data/registry.yaml``, tracked).

Each entry names a file the pipeline obtains from outside (a real JRC trace)
and the sha256 it must have.  The pipeline only reads the registry, except in
trust-on-first-use mode, which the user must ask for explicitly
(``real_traces.trust_on_first_use: true``): then a missing sha256 is filled
in with the one observed, and the pipeline says so.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import yaml

from ..atomic import atomic_target

HEADER = """# Registry of EXTERNAL datasets (tracked).  Each entry: the sha256 the file
# must have, plus a description.  Where a file comes from is set in the config
# (real_traces.sources); see docs/data.md.  Synthetic datasets are not listed
# here: data/manifest.json records them.
"""


def read_registry(path: str | Path) -> dict[str, Any]:
    path = Path(path)
    if not path.exists():
        return {"datasets": {}}
    data = yaml.safe_load(path.read_text()) or {}
    if not isinstance(data.get("datasets", {}), dict):
        raise ValueError(f"{path}: 'datasets' must be a mapping of name -> entry")
    data.setdefault("datasets", {})
    return data


def expected_sha256(path: str | Path, name: str) -> str | None:
    entry = read_registry(path)["datasets"].get(name) or {}
    sha = entry.get("sha256")
    return str(sha).lower() if sha else None


def record_sha256(path: str | Path, name: str, sha256: str, note: str) -> None:
    """Trust on first use: store the observed sha256 (atomic rewrite)."""
    path = Path(path)
    data = read_registry(path)
    entry = dict(data["datasets"].get(name) or {})
    entry.update({"sha256": sha256, "recorded": note})
    data["datasets"][name] = entry
    fd, tmp = atomic_target(path)
    with os.fdopen(fd, "w") as fh:
        fh.write(HEADER + yaml.safe_dump(data, sort_keys=True))
    os.replace(tmp, path)
