"""A byte-reproducible tar.gz and the SHA256SUMS manifest of a bundle.

Members are sorted by name, every mtime is fixed (``MTIME``, 2000-01-01),
uid/gid 0 with empty owner names, modes 0644, no PAX timestamps, and the gzip
header carries no file name and a zero mtime, so archiving the same files
twice gives the same sha256 on any machine.
"""

from __future__ import annotations

import gzip
import hashlib
import io
import os
import tarfile
from collections.abc import Mapping

from ..atomic import atomic_bytes

MTIME = 946684800  # 2000-01-01T00:00:00Z
SUMS = "SHA256SUMS"


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def sums_text(members: Mapping[str, bytes]) -> str:
    """``sha256  name`` lines over every member except the SHA256SUMS file itself, sorted by name."""
    return "".join(f"{sha256_bytes(members[name])}  {name}\n" for name in sorted(members) if name != SUMS)


def parse_sums(text: str) -> dict[str, str]:
    out = {}
    for line in text.splitlines():
        if line.strip():
            digest, name = line.split(None, 1)
            out[name.strip().lstrip("*")] = digest
    return out


def write_tarball(members: Mapping[str, bytes], path: str | os.PathLike, root: str) -> str:
    """Write ``members`` (arcname -> bytes) under ``root/`` atomically; return the archive's sha256."""
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w", format=tarfile.USTAR_FORMAT) as tar:
        for name in sorted(members):
            data = members[name]
            info = tarfile.TarInfo(f"{root}/{name}")
            info.size = len(data)
            info.mtime = MTIME
            info.mode = 0o644
            info.uid = info.gid = 0
            info.uname = info.gname = ""
            tar.addfile(info, io.BytesIO(data))
    raw = io.BytesIO()
    with gzip.GzipFile(filename="", mode="wb", fileobj=raw, mtime=0, compresslevel=9) as gz:
        gz.write(buf.getvalue())
    data = raw.getvalue()
    atomic_bytes(path, data)
    return sha256_bytes(data)


def read_tarball(path: str | os.PathLike) -> dict[str, bytes]:
    """Members of a bundle (names without the root folder)."""
    out = {}
    with tarfile.open(path, "r:gz") as tar:
        for info in tar.getmembers():
            if info.isfile():
                name = info.name.split("/", 1)[1] if "/" in info.name else info.name
                out[name] = tar.extractfile(info).read()
    return out
