"""Check a bundle (tar.gz or unpacked folder) against its own SHA256SUMS, and
optionally the content hashes of freshly regenerated results against it.

One line per problem: ``CHANGED name``, ``MISSING name``, ``EXTRA name``,
``RESULT-DIFFERS name``, ``RESULT-MISSING name``.  No lines means verified.
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
    if against is not None:
        problems += check_results(members, against)
    return problems
