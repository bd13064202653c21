"""The registry of external datasets (``data/registry.yaml``, tracked).

Each entry names a file the pipeline obtains from outside (a real JRC trace)
and the sha256 it must have.  The pipeline only reads the registry, except in
trust-on-first-use mode, which the user must ask for explicitly
(``real_traces.trust_on_first_use: true``): then a missing sha256 is filled
in with the one observed, and the pipeline says so.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

from ..atomic import atomic_bytes
from ..errors import InputError
from ..yamlio import yaml_load

HEADER = """# Registry of EXTERNAL datasets (tracked).  Each entry: the sha256 the file
# must have, plus a description.  Where a file comes from is set in the config
# (real_traces.sources); see docs/data.md.  Synthetic datasets are not listed
# here: data/manifest.json records them.
"""


class RegistryError(InputError):
    """The registry file is not valid YAML or does not follow the layout above."""


def read_registry(path: str | Path) -> dict[str, Any]:
    """The registry at ``path`` ({"datasets": {}} if the file does not exist yet, e.g. before trust on first use)."""
    path = Path(path)
    if not path.exists():
        return {"datasets": {}}
    try:
        data = yaml_load(path.read_text(encoding="utf-8")) or {}
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark is not None else str(path)
        raise RegistryError(f"{where}: the dataset registry is not valid YAML; fix its syntax (layout in docs/data.md)") from None
    if not isinstance(data, dict) or not isinstance(data.get("datasets", {}), dict):
        raise RegistryError(f"{path}: 'datasets' must be a mapping of name -> entry (docs/data.md); fix the file")
    data.setdefault("datasets", {})
    for name, entry in data["datasets"].items():
        sha = (entry or {}).get("sha256") if isinstance(entry, dict) or entry is None else None
        if not (isinstance(entry, dict) or entry is None):
            raise RegistryError(f"{path}: entry {name!r} must be a mapping with a 'sha256' key; fix the file")
        if sha and not re.fullmatch(r"[0-9a-fA-F]{64}", str(sha)):
            raise RegistryError(f"{path}: datasets.{name}.sha256 is not 64 hex digits ({str(sha)[:20]!r}); put the file's sha256 there")
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
    atomic_bytes(path, HEADER + yaml.safe_dump(data, sort_keys=True))
