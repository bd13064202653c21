"""A bundle's tar.gz: written byte-reproducibly, read back strictly, and its SHA256SUMS manifest.

Writing: members are sorted by name, every mtime is fixed (``MTIME``,
2000-01-01), uid/gid 0 with empty owner names, modes 0644, no PAX timestamps,
and the gzip header carries no file name and a zero mtime, so archiving the
same files twice gives the same sha256 on any machine.  Every member is a
regular file under one root folder.

Reading (:func:`read_tarball`, used by ``verify``): the whole compressed
stream is read to its end in memory, nothing is extracted to disk, so gzip
checks the CRC and length of every gzip member and a truncated stream is
noticed even when the cut falls after the last tar member.  Then every tar
member is judged against what the writer makes: only regular files (and
folders) under the single root folder, no links, devices or fifos, no
setuid/setgid/sticky bits, no absolute or ``..`` paths, no name twice,
nothing after the tar's end-of-archive blocks but zeros.  Each departure is one problem line, and
reading goes on to the end, so all of them are reported.
"""

from __future__ import annotations

import gzip
import hashlib
import io
import os
import re
import tarfile
import zlib
from collections.abc import Mapping
from typing import NamedTuple

from ..atomic import atomic_bytes
from ..errors import one_line

MTIME = 946684800  # 2000-01-01T00:00:00Z
SUMS = "SHA256SUMS"
_SUMS_LINE = re.compile(r"([0-9a-fA-F]{64}) [ *](.+)")
_LINK_OR_SPECIAL = {
    tarfile.SYMTYPE: "symbolic link",
    tarfile.LNKTYPE: "hard link",
    tarfile.CHRTYPE: "character device",
    tarfile.BLKTYPE: "block device",
    tarfile.FIFOTYPE: "named pipe (fifo)",
}


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def sums_text(members: Mapping[str, bytes]) -> str:
    """``sha256  name`` lines over every member except the SHA256SUMS file itself, sorted by name."""
    return "".join(f"{sha256_bytes(members[name])}  {name}\n" for name in sorted(members) if name != SUMS)


def parse_sums(text: str) -> dict[str, str]:
    """Name -> sha256 of a ``sha256sum`` listing; a line that is not ``<64 hex digits>  <name>`` raises ``ValueError``."""
    out = {}
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        match = _SUMS_LINE.fullmatch(line.rstrip())
        if match is None:
            raise ValueError(f"line {number} is not a sha256 (64 hex digits), two blanks and a name: {line[:60]!r}")
        out[match.group(2)] = match.group(1).lower()
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


class Contents(NamedTuple):
    """What a bundle holds, as far as it can be read."""

    members: dict[str, bytes]  # regular files, names relative to the bundle's root folder
    problems: list[str]  # one line per problem of the container itself
    damaged: set[str]  # members present but not readable to their end (already reported)
    opened: bool = True  # False: nothing could be read at all (the problems say why)
    complete: bool = True  # False: the stream breaks off, members after the break are lost


class _Entry(NamedTuple):
    info: tarfile.TarInfo
    data: bytes | None
    error: str | None


def _decompress(fh) -> tuple[io.BytesIO, str | None]:
    """The tar stream inside a gzip file, read to its end, and why it is damaged (``None`` if it is not).

    On damage the data decompressed up to the damage are kept: the members
    they hold can still be checked.
    """
    out = io.BytesIO()
    try:
        with gzip.GzipFile(fileobj=fh, mode="rb") as gz:
            while chunk := gz.read1(1 << 20):
                out.write(chunk)
    except EOFError:
        return out, "compressed stream truncated: it ends before its end-of-stream marker"
    except (OSError, zlib.error) as exc:  # gzip.BadGzipFile is an OSError
        return out, f"compressed stream corrupt: {one_line(exc)}"
    return out, None


def _tar_entries(buf: io.BytesIO) -> tuple[list[_Entry], int | None, str | None]:
    """Every member tarfile can read from ``buf`` (with its data), where the last one ended, and why reading stopped early."""
    buf.seek(0)
    try:
        tar = tarfile.open(fileobj=buf, mode="r:")
    except Exception as exc:  # noqa: BLE001 (tarfile raises many kinds on a corrupt header)
        return [], None, f"no tar archive inside ({one_line(exc)})"
    entries = []
    while True:
        try:
            info = tar.next()
        except Exception as exc:  # noqa: BLE001 (as above)
            return entries, None, f"unreadable tar header ({one_line(exc)})"
        if info is None:
            return entries, tar.offset, None
        data = error = None
        if info.isreg():
            try:
                data = tar.extractfile(info).read()
            except Exception as exc:  # noqa: BLE001 (as above)
                error = one_line(exc)
        entries.append(_Entry(info, data, error))


def _parts(name: str) -> list[str]:
    return [part for part in name.split("/") if part not in ("", ".")]


def _root(entries: list[_Entry]) -> str | None:
    """The bundle's root folder: the one holding SHA256SUMS, else the first member's."""
    tops = [_parts(e.info.name) for e in entries if e.info.isreg() and not e.info.name.startswith("/")]
    with_sums = sorted({p[0] for p in tops if len(p) == 2 and p[1] == SUMS and p[0] != ".."})
    if len(with_sums) == 1:
        return with_sums[0]
    nested = [p[0] for p in tops if len(p) > 1 and p[0] != ".."]
    return nested[0] if nested else None


def _unsafe(info: tarfile.TarInfo) -> str | None:
    """Why extracting ``info`` could write outside its folder or create something other than a plain file."""
    if info.name.startswith("/"):
        return "absolute path: extracting it writes outside the folder it is extracted into"
    if ".." in info.name.split("/"):
        return "'..' in its path: extracting it can write outside the folder it is extracted into"
    if info.type in _LINK_OR_SPECIAL:
        kind = _LINK_OR_SPECIAL[info.type]
        target = f" to {info.linkname}" if info.issym() or info.islnk() else ""
        return f"{kind}{target}; a bundle holds only regular files"
    if not (info.isreg() or info.isdir()):
        return f"tar member of type {info.type!r}, not a regular file"
    if info.mode & 0o7000:
        return f"mode {info.mode:04o} sets setuid, setgid or sticky bits, which tar run as root restores; the archive rule writes 0644"
    return None


def read_tarball(path: str | os.PathLike) -> Contents:
    """The regular files of a bundle (names without the root folder) and one line per problem of the archive.

    Kinds: ``UNREADABLE`` (not a gzip-compressed tar at all), ``DAMAGED``
    (corrupt or truncated stream, a member cut short, a bad header, data
    hidden after the end), ``UNSAFE`` (link, device, fifo, absolute or ``..``
    path), ``OUTSIDE`` (not under the root folder), ``DUPLICATE``.
    """
    shown = os.fspath(path)
    try:
        with open(path, "rb") as fh:
            magic = fh.read(2)
            fh.seek(0)
            if magic != b"\x1f\x8b":
                return Contents({}, [f"UNREADABLE {shown} (not a gzip file: a bundle is the .tar.gz the archive rule writes, or its unpacked folder)"], set(), False)
            buf, stream_error = _decompress(fh)
    except OSError as exc:
        return Contents({}, [f"UNREADABLE {shown} (cannot be read: {exc.strerror or one_line(exc)})"], set(), False)
    entries, end, tar_error = _tar_entries(buf)
    if not entries and tar_error and not stream_error:
        return Contents({}, [f"UNREADABLE {shown} ({tar_error})"], set(), False)

    root = _root(entries)
    members: dict[str, bytes] = {}
    problems: list[str] = []
    damaged: set[str] = set()
    counts: dict[str, int] = {}
    for entry in entries:
        info, parts = entry.info, _parts(entry.info.name)
        rel = "/".join(parts[1:]) if root is not None and parts[:1] == [root] and len(parts) > 1 else None
        reason = _unsafe(info)
        if reason:
            escapes = info.name.startswith("/") or ".." in parts
            problems.append(f"UNSAFE {info.name if rel is None or escapes else rel} ({reason})")
        elif rel is None:
            if not (info.isdir() and parts == [root]):
                where = f"the bundle's root folder {root}/" if root else "a root folder (the bundle has none)"
                problems.append(f"OUTSIDE {info.name} (not under {where}: extracting it adds a file the checksums do not cover)")
        elif info.isdir():
            continue
        elif entry.error is not None:
            damaged.add(rel)
            why = stream_error or "the tar data end inside it"
            problems.append(f"DAMAGED {rel} (cut short in {shown}: {why})")
        else:
            counts[rel] = counts.get(rel, 0) + 1
            members[rel] = entry.data  # extraction keeps the last of duplicates, so check that one
    problems += [f"DUPLICATE {rel} ({n} members with this name: extracting keeps only the last)" for rel, n in counts.items() if n > 1]

    last = f" after member {entries[-1].info.name}" if entries else ""
    if damaged:
        pass  # the break is reported at the member it cut short
    elif stream_error:
        problems.append(f"DAMAGED {shown} ({stream_error}; gzip -t rejects it)")
    elif tar_error:
        problems.append(f"DAMAGED {shown} ({tar_error}{last})")
    elif end is not None:
        tail = buf.getbuffer()[end:]
        if bytes(tail).strip(b"\0"):
            problems.append(f"DAMAGED {shown} ({len(tail)} bytes{last} are not the tar's end-of-archive zeros: a damaged header or data hidden after the end)")
        elif len(tail) < 2 * tarfile.BLOCKSIZE:
            problems.append(f"DAMAGED {shown} (the tar archive has no end-of-archive marker{last})")
    return Contents(members, problems, damaged, True, stream_error is None and tar_error is None)
