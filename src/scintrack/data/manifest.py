"""The dataset manifest: name, version, source and checksums of every dataset.

Built by a rule from the attributes that each dataset file carries, so it
never needs editing by hand (``data/manifest.json``, git-ignored).  External
datasets' *expected* checksums live in the tracked ``data/registry.yaml``.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path

import xarray as xr

from ..io import sha256_file

FIELDS = ("dataset_name", "dataset_version", "generator", "generator_version", "source", "content_sha256", "seed", "params")


def manifest_entry(path: str | Path) -> dict:
    """A dataset's entry from its NetCDF attributes, or from the JSON sidecar of a binary recording."""
    if Path(path).suffix == ".json":
        attrs = json.loads(Path(path).read_text())
        entry = {key: attrs.get(key) for key in FIELDS}
        entry.update(path=str(Path(path).with_name(attrs["data_file"])), sha256=attrs["sha256"], content_sha256=attrs["sha256"],
                     sidecar=str(path), sidecar_sha256=sha256_file(path))
        return entry
    with xr.open_dataset(path, engine="netcdf4") as ds:
        attrs = dict(ds.attrs)
    entry = {key: attrs.get(key) for key in FIELDS}
    if isinstance(entry.get("params"), str):
        entry["params"] = json.loads(entry["params"])
    entry["path"] = str(path)
    entry["sha256"] = sha256_file(path)
    return entry


def build_manifest(paths: Iterable[str | Path]) -> dict:
    entries = sorted((manifest_entry(p) for p in paths), key=lambda e: (e["dataset_name"] or "", e["dataset_version"] or ""))
    return {"datasets": entries}
