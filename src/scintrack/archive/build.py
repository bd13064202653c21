"""Assemble the publication bundle from a finished results tree.

Contents (``docs/archive.md``): every figure and table with their
SHA256SUMS, the result NetCDF files up to ``max_result_mb`` each (larger ones
are listed with their file and content hashes in ``results_manifest.json``),
the dataset manifest and the external-data registry, the config used,
``environment.lock``, the comparison page, provenance, CITATION.cff,
.zenodo.json, ro-crate-metadata.json and ``SHA256SUMS`` over all of it.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import yaml

from ..checksums import read_checksums
from ..io import content_hash, open_dataset, read_attrs, sha256_file
from . import metadata
from .tarball import SUMS, sums_text


class ArchiveRefused(RuntimeError):
    """The tree is not fit to archive (one-line reason)."""


def check_tree(git: Mapping[str, Any], allow_dirty: bool, checksum_files: Iterable[str | Path]) -> None:
    """Refuse a dirty checkout (unless allowed) and a figure/table tree that disagrees with its SHA256SUMS."""
    if git.get("git_dirty") and not allow_dirty:
        raise ArchiveRefused(
            "archive: the git checkout has uncommitted changes (results may not match any commit); commit them, "
            "or add --configfile config/allow-dirty.yaml to archive anyway (recorded as dirty)"
        )
    for sums in map(Path, checksum_files):
        for rel, digest in read_checksums(sums).items():
            path = sums.parent / rel
            if not path.exists():
                raise ArchiveRefused(f"archive: {path} is listed in {sums} but missing: the results tree is incomplete; rerun snakemake")
            if sha256_file(path) != digest:
                raise ArchiveRefused(f"archive: {path} does not match {sums}: the results tree changed after it was built; rerun snakemake")


def check_results_config(config: Mapping[str, Any], results: Iterable[str | Path]) -> None:
    """Refuse results whose recorded config hash is not the one the archived ``config`` gives."""
    from ..pipeline.consistency import mismatches

    recorded = {Path(p).as_posix(): read_attrs(p).get("config_sha256") for p in results}
    problems = mismatches(config, recorded)
    if problems:
        first = problems[0].removeprefix("CONFIG-DIFFERS ")
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise ArchiveRefused(f"archive: {first}{more}; rerun snakemake with this config before archiving")


def version_of(package_version: str, git: Mapping[str, Any]) -> str:
    commit = str(git.get("git_commit") or "unknown")[:10]
    return f"{package_version}+g{commit}" + (".dirty" if git.get("git_dirty") else "")


def collect_members(
    *,
    outputs: Iterable[str | Path],
    results: Iterable[str | Path],
    extra: Mapping[str, str | Path],
    max_result_mb: float,
) -> tuple[dict[str, bytes], dict[str, Any]]:
    """Bundle members (arcname -> bytes) and the results manifest."""
    members: dict[str, bytes] = {}
    for path in map(Path, outputs):
        members[path.as_posix()] = path.read_bytes()
    manifest: dict[str, Any] = {"content_sha256": {}, "config_sha256": {}, "sha256": {}, "included": [], "listed_only": [], "max_result_mb": max_result_mb}
    for path in sorted(map(Path, results)):
        rel = path.as_posix()
        ds = open_dataset(path)
        manifest["content_sha256"][rel] = content_hash(ds)
        manifest["config_sha256"][rel] = ds.attrs.get("config_sha256")
        manifest["sha256"][rel] = sha256_file(path)
        if path.stat().st_size <= max_result_mb * 1e6:
            members[rel] = path.read_bytes()
            manifest["included"].append(rel)
        else:
            manifest["listed_only"].append(rel)
    for arcname, path in extra.items():
        members[arcname] = Path(path).read_bytes()
    members["results_manifest.json"] = (json.dumps(manifest, indent=2, sort_keys=True) + "\n").encode()
    return members, manifest


def finish(members: dict[str, bytes], *, config: Mapping[str, Any], git: Mapping[str, Any], timings: list, name: str, version: str) -> dict[str, bytes]:
    """Add config, provenance, citation, Zenodo and RO-Crate metadata, then SHA256SUMS."""
    from .. import __version__

    members["config/config.yaml"] = yaml.safe_dump(dict(config), sort_keys=True).encode()
    members["provenance.json"] = metadata.provenance(
        config=config, git=git, lock_text=members.get("environment.lock", b"").decode(), timings=timings, name=name, version=version
    )
    members["CITATION.cff"] = metadata.citation_cff(__version__, str(git.get("git_commit")))
    members[".zenodo.json"] = metadata.zenodo_json(version)
    members["ro-crate-metadata.json"] = metadata.ro_crate(members, name=name, version=version, commit=str(git.get("git_commit")))
    members[SUMS] = sums_text(members).encode()
    return members
