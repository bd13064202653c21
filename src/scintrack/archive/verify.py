"""Check a bundle (tar.gz or unpacked folder) against its own SHA256SUMS, and
optionally the content hashes of freshly regenerated results against it.

One line per problem, each a kind word and the member it concerns, and every
problem is reported (reading never stops at the first).  No lines means
verified.

* The container (:func:`scintrack.archive.tarball.read_tarball` for a
  tar.gz, :func:`load_folder` for a folder): ``UNREADABLE`` (cannot be opened
  at all), ``DAMAGED`` (corrupt or truncated stream, a member cut short),
  ``UNSAFE`` (a link, device or fifo, an absolute or ``..`` path),
  ``OUTSIDE`` (a member not under the bundle's single root folder),
  ``DUPLICATE`` (a name twice).
* The checksums: ``CHANGED``, ``MISSING``, ``EXTRA``; ``MALFORMED`` for a
  SHA256SUMS, ``results_manifest.json`` or ``config/config.yaml`` that cannot
  be read.
* The results: ``RESULT-UNREADABLE`` (a packed NetCDF that cannot be read),
  ``CONFIG-DIFFERS`` (a result whose recorded config hash is not the one the
  bundle's own ``config/config.yaml`` gives), and with a tree to compare:
  ``RESULT-DIFFERS``, ``RESULT-MISSING``.

Nothing is extracted to disk: members are read into memory.
"""

from __future__ import annotations

import json
import os
import stat
from collections.abc import Collection
from pathlib import Path
from typing import Any

from ..errors import InputError, one_line
from .tarball import SUMS, Contents, parse_sums, read_tarball, sha256_bytes

MANIFEST = "results_manifest.json"
CONFIG = "config/config.yaml"


class BundleNotFound(InputError):
    """The path given to verify is neither an archive nor a folder."""


def load_folder(path: Path) -> Contents:
    """The regular files of an unpacked bundle; symlinks and special files are ``UNSAFE`` and never followed or opened."""
    members: dict[str, bytes] = {}
    problems: list[str] = []

    def unreadable(exc: OSError) -> None:
        rel = Path(exc.filename).relative_to(path).as_posix() if exc.filename else str(path)
        problems.append(f"UNREADABLE {rel} ({exc.strerror or one_line(exc)})")

    for folder, dirs, files in os.walk(path, onerror=unreadable):
        dirs.sort()
        for name in sorted(dirs + files):
            full = Path(folder, name)
            rel = full.relative_to(path).as_posix()
            try:
                mode = os.lstat(full).st_mode
                if stat.S_ISLNK(mode):
                    problems.append(f"UNSAFE {rel} (symbolic link to {os.readlink(full)}: a bundle holds only regular files)")
                elif stat.S_ISREG(mode):
                    members[rel] = full.read_bytes()
                elif not stat.S_ISDIR(mode):
                    problems.append(f"UNSAFE {rel} (a device, fifo or socket, not a regular file)")
            except OSError as exc:
                problems.append(f"UNREADABLE {rel} ({exc.strerror or one_line(exc)})")
    return Contents(dict(sorted(members.items())), problems, set())


def load_bundle(path: str | Path) -> Contents:
    path = Path(path)
    if path.is_dir():
        return load_folder(path)
    if not path.exists():
        raise BundleNotFound(f"{path}: no such archive or folder; give the .tar.gz the archive rule wrote (archive/<name>-<version>.tar.gz) or its unpacked folder")
    if not path.is_file():
        return Contents({}, [f"UNREADABLE {path} (neither a file nor a folder)"], set(), False)
    return read_tarball(path)


def check_sums(members: dict[str, bytes], damaged: Collection[str] = ()) -> list[str]:
    """Every member against SHA256SUMS; members in ``damaged`` are already reported and skipped."""
    if SUMS not in members:
        return [] if SUMS in damaged else [f"MISSING {SUMS} (not a bundle made by the archive rule?)"]
    try:
        listed = parse_sums(members[SUMS].decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        return [f"MALFORMED {SUMS} ({one_line(exc)}): the checksums of the bundle cannot be checked"]
    problems = []
    for name, digest in sorted(listed.items()):
        if name in damaged:
            continue
        if name not in members:
            problems.append(f"MISSING {name}")
        elif sha256_bytes(members[name]) != digest:
            problems.append(f"CHANGED {name} (sha256 {sha256_bytes(members[name])[:16]}..., listed {digest[:16]}...)")
    for name in sorted(set(members) - set(listed) - {SUMS}):
        problems.append(f"EXTRA {name} (not listed in {SUMS})")
    return problems


def read_manifest(members: dict[str, bytes]) -> tuple[dict[str, Any] | None, list[str]]:
    """The results manifest, or ``None`` and a ``MALFORMED`` line (nothing if it is absent: check_sums reports that)."""
    if MANIFEST not in members:
        return None, []
    try:
        manifest = json.loads(members[MANIFEST])
    except (UnicodeDecodeError, ValueError) as exc:
        return None, [f"MALFORMED {MANIFEST} (not JSON: {one_line(exc)[:120]})"]
    shapes = {"content_sha256": dict, "config_sha256": dict, "included": list}
    if not isinstance(manifest, dict) or any(not isinstance(manifest.get(key, shape()), shape) for key, shape in shapes.items()):
        return None, [f"MALFORMED {MANIFEST} (not a mapping with content_sha256, config_sha256 and included)"]
    if not all(isinstance(k, str) and isinstance(v, str) for k, v in manifest.get("content_sha256", {}).items()):
        return None, [f"MALFORMED {MANIFEST} (content_sha256 is not a mapping of result path to hash)"]
    if not all(isinstance(rel, str) for rel in manifest.get("included", [])):
        return None, [f"MALFORMED {MANIFEST} (included is not a list of result paths)"]
    for key, shape in shapes.items():
        manifest.setdefault(key, shape())
    return manifest, []


def _nc_attr(data: bytes, rel: str, name: str):
    import netCDF4

    with netCDF4.Dataset(rel, mode="r", memory=data) as nc:
        return nc.getncattr(name) if name in nc.ncattrs() else None


def check_config(members: dict[str, bytes], manifest: dict[str, Any] | None) -> list[str]:
    """Every packed result readable, and every result (packed, or listed by hash) against the bundle's config."""
    import yaml

    from ..pipeline.consistency import mismatches
    from ..yamlio import yaml_load

    if manifest is None:
        return []  # reported by check_sums / read_manifest
    problems = []
    recorded = dict(manifest.get("config_sha256", {}))
    unreadable = set()
    for rel in manifest.get("included", []):
        if rel in members:  # the packed file itself, not only the manifest's copy of its hash
            try:
                recorded[rel] = _nc_attr(members[rel], rel, "config_sha256")
            except (OSError, RuntimeError, ValueError, KeyError, IndexError, TypeError) as exc:  # what netCDF4 raises on a corrupt file
                unreadable.add(rel)
                reason = one_line(getattr(exc, "strerror", None) or exc).split(": '", 1)[0][:120]
                problems.append(f"RESULT-UNREADABLE {rel} (not a readable NetCDF file: {reason})")
    if CONFIG not in members:
        return problems
    malformed = None
    try:
        config = yaml_load(members[CONFIG])
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        config, malformed = None, f"not YAML: {one_line(exc)[:120]}"
    if malformed is None and not isinstance(config, dict):
        malformed = "not a mapping"
    if malformed is None:
        try:
            problems += mismatches(config, {rel: h for rel, h in recorded.items() if rel not in unreadable})
        except (ValueError, KeyError, TypeError, AttributeError) as exc:  # a config without the values a result depends on
            malformed = f"it does not give the values the results depend on: {type(exc).__name__} {one_line(exc)[:120]}"
    if malformed is not None:
        problems.append(f"MALFORMED {CONFIG} ({malformed})")
    unknown = sorted(set(manifest["content_sha256"]) - set(recorded) - unreadable)
    problems += [f"CONFIG-DIFFERS {rel} (no config hash recorded)" for rel in unknown]
    return problems


def check_results(manifest: dict[str, Any] | None, tree: str | Path) -> list[str]:
    """Content hashes of the results regenerated in ``tree`` against the bundle's results manifest."""
    from ..io import DatasetReadError, content_hash, open_dataset

    if manifest is None:
        return []  # reported by check_sums / read_manifest
    problems = []
    for rel, expected in sorted(manifest["content_sha256"].items()):
        path = Path(tree) / rel
        if not path.exists():
            problems.append(f"RESULT-MISSING {rel} (not in {tree})")
            continue
        try:
            actual = content_hash(open_dataset(path))
        except DatasetReadError as exc:
            problems.append(f"RESULT-UNREADABLE {rel} (the regenerated file: {exc})")
            continue
        if actual != expected:
            problems.append(f"RESULT-DIFFERS {rel} (content {actual[:16]}..., archived {expected[:16]}...)")
    return problems


def verify(bundle: str | Path, against: str | Path | None = None) -> list[str]:
    """Every problem of ``bundle`` (and of the results in ``against`` against it), one line each."""
    contents = load_bundle(bundle)
    problems = list(contents.problems)
    if not contents.opened:
        return problems
    if SUMS in contents.members or contents.complete:  # else SHA256SUMS was lost to the damage already reported
        problems += check_sums(contents.members, contents.damaged)
    manifest, bad = read_manifest(contents.members)
    problems += bad
    problems += check_config(contents.members, manifest)
    if against is not None:
        missing = f"MISSING {MANIFEST}"
        if MANIFEST not in contents.members and MANIFEST not in contents.damaged and missing not in problems:
            problems.append(missing)
        problems += check_results(manifest, against)
    return problems
