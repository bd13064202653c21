"""Check a bundle (tar.gz or unpacked folder) against its own SHA256SUMS, and
optionally the content hashes of freshly regenerated results against it.

One line per problem: ``CHANGED name``, ``MISSING name``, ``EXTRA name``,
``CONFIG-DIFFERS name`` (a result whose recorded config hash is not the one
the bundle's own ``config/config.yaml`` gives), ``RESULT-DIFFERS name``,
``RESULT-MISSING name``.  No lines means verified.
"""

from __future__ import annotations

import json
from pathlib import Path

from .tarball import SUMS, parse_sums, read_tarball, sha256_bytes


def load_bundle(path: str | Path) -> dict[str, bytes]:
    path = Path(path)
    if path.is_dir():
        return {p.relative_to(path).as_posix(): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()}
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such archive or folder")
    return read_tarball(path)


def check_sums(members: dict[str, bytes]) -> list[str]:
    if SUMS not in members:
        return [f"MISSING {SUMS} (not a bundle made by the archive rule?)"]
    listed = parse_sums(members[SUMS].decode())
    problems = []
    for name, digest in sorted(listed.items()):
        if name not in members:
            problems.append(f"MISSING {name}")
        elif sha256_bytes(members[name]) != digest:
            problems.append(f"CHANGED {name} (sha256 {sha256_bytes(members[name])[:16]}..., listed {digest[:16]}...)")
    for name in sorted(set(members) - set(listed) - {SUMS}):
        problems.append(f"EXTRA {name} (not listed in {SUMS})")
    return problems


def _nc_attr(data: bytes, name: str):
    import netCDF4

    with netCDF4.Dataset("bundle-member.nc", mode="r", memory=data) as nc:
        return nc.getncattr(name) if name in nc.ncattrs() else None


def check_config(members: dict[str, bytes]) -> list[str]:
    """Every result (packed, or listed by hash) against the bundle's config."""
    from ..pipeline.consistency import mismatches
    from ..yamlio import yaml_load

    if "config/config.yaml" not in members or "results_manifest.json" not in members:
        return []  # reported by check_sums / check_results
    config = yaml_load(members["config/config.yaml"])
    manifest = json.loads(members["results_manifest.json"])
    recorded = dict(manifest.get("config_sha256", {}))
    for rel in manifest.get("included", []):
        if rel in members:  # the packed file itself, not only the manifest's copy of its hash
            recorded[rel] = _nc_attr(members[rel], "config_sha256")
    problems = mismatches(config, recorded)
    unknown = sorted(set(manifest["content_sha256"]) - set(recorded))
    problems += [f"CONFIG-DIFFERS {rel} (no config hash recorded)" for rel in unknown]
    return problems


def check_results(members: dict[str, bytes], tree: str | Path) -> list[str]:
    """Content hashes of the results regenerated in ``tree`` against the bundle's results manifest."""
    from ..io import content_hash, open_dataset

    if "results_manifest.json" not in members:
        return ["MISSING results_manifest.json"]
    manifest = json.loads(members["results_manifest.json"])
    problems = []
    for rel, expected in sorted(manifest["content_sha256"].items()):
        path = Path(tree) / rel
        if not path.exists():
            problems.append(f"RESULT-MISSING {rel} (not in {tree})")
            continue
        actual = content_hash(open_dataset(path))
        if actual != expected:
            problems.append(f"RESULT-DIFFERS {rel} (content {actual[:16]}..., archived {expected[:16]}...)")
    return problems


def verify(bundle: str | Path, against: str | Path | None = None) -> list[str]:
    members = load_bundle(bundle)
    problems = check_sums(members)
    problems += check_config(members)
    if against is not None:
        problems += check_results(members, against)
    return problems
