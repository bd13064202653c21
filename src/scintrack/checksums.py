"""``SHA256SUMS`` manifests (sha256sum format) of figures and tables.

Each manifest is the output of one rule (``figure_checksums``,
``table_checksums``) that lists every file of its folder tree; names are
relative to the manifest's folder, sorted, so the manifest is byte-stable.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from .io import sha256_file, write_text


def read_checksums(path: Path) -> dict[str, str]:
    sums = {}
    if path.exists():
        for line in path.read_text().splitlines():
            if line.strip():
                digest, name = line.split(maxsplit=1)
                sums[name.lstrip("*")] = digest
    return sums


def write_checksums(manifest: str | os.PathLike, files: Iterable[str | os.PathLike]) -> Path:
    """Write ``manifest`` (``SHA256SUMS``, sha256sum format) listing ``files``
    relative to its folder, sorted, atomically (the rule that owns it calls this)."""
    manifest = Path(manifest)
    folder = manifest.parent.resolve()
    sums = {Path(f).resolve().relative_to(folder).as_posix(): sha256_file(f) for f in files}
    write_text("".join(f"{sums[k]}  {k}\n" for k in sorted(sums)), manifest)
    return manifest
