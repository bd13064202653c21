"""Atomic file writes: a temporary file beside the target, then ``os.replace``.

Every output of the pipeline is written through :func:`atomic_write` (or
:func:`atomic_bytes`), so a reader never sees a half-written file, an
existing output is replaced only by a complete new one, and a failed or
killed write leaves the old file as it was.

* **Mode.** The temporary file gets the mode a plain ``open()`` would
  (``0666 & ~umask``): ``tempfile.mkstemp`` alone creates files with mode
  0600, which would leave outputs unreadable to the group and others.
* **Names.** ``.<target name>.<host>-<pid>.<random>.scintrack-tmp``: hidden,
  recognisable, and naming the process that writes it.  A process killed
  mid-write (SIGKILL, power cut) leaves its temporary file behind;
  :func:`clean_stale` (called when a Snakemake run starts) removes those of
  processes on this host that no longer run, and never a file another live
  run is writing.
* **Errors.** A full disk, a read-only or unwritable folder: the write
  raises :class:`OutputWriteError` (an :class:`~scintrack.errors.InputError`,
  so a workflow script reports it as one line) naming the file and the fix,
  after removing its temporary file.
* **Fault injection.** ``SCINTRACK_HOLD_BEFORE_RENAME=SECONDS`` makes every
  write of an output wait that long between the complete temporary file and
  the rename: the kill-and-resume test uses it to kill a job in the middle of
  a write.  Bookkeeping files that are no pipeline output (the code-version
  cache, written by Snakemake's own process while it builds the DAG) pass
  ``hold=False``: holding each of their writes would delay the first job of
  a fresh folder by a minute and a half.

No heavy imports: the data registry uses it while Snakemake builds the DAG.
"""

from __future__ import annotations

import errno
import os
import socket
import tempfile
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from .errors import InputError

SUFFIX = ".scintrack-tmp"
_DISK_FULL = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG}
_NOT_WRITABLE = {errno.EACCES, errno.EPERM, errno.EROFS}


class OutputWriteError(InputError):
    """An output could not be written (disk full, read-only folder, ...); nothing was changed."""


def host_name() -> str:
    """This host's short name, as temporary files name their writer."""
    return socket.gethostname().split(".")[0].replace("-", "_") or "host"


def write_failure(path: Path, exc: OSError) -> OutputWriteError:
    """The one-line error for a failed write of ``path``."""
    code = getattr(exc, "errno", None)
    reason = exc.strerror or str(exc) or type(exc).__name__
    if code in _DISK_FULL:
        fix = f"free disk space on the file system of {path.parent} (or lift the file-size limit), then rerun"
    elif code in _NOT_WRITABLE:
        fix = f"make {path.parent} writable (or run in a folder you can write to), then rerun"
    else:
        fix = f"check free disk space and that {path.parent} is writable, then rerun"
    return OutputWriteError(f"{path}: could not write it ({reason}); {fix}; the previous file, if any, is unchanged")


def atomic_target(path: Path, suffix: str = SUFFIX) -> tuple[int, str]:
    """(open descriptor, name) of a new temporary file beside ``path`` with a normal mode."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.{host_name()}-{os.getpid()}.", suffix=suffix, dir=path.parent)
    except OSError as exc:
        raise write_failure(path, exc) from None
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    return fd, tmp


def atomic_write(path: str | os.PathLike, write: Callable[[str], object], *, hold: bool = True) -> None:
    """Call ``write(temporary_name)`` to fill a temporary file, then rename it onto ``path``.

    ``hold``: honour ``SCINTRACK_HOLD_BEFORE_RENAME`` (the module docstring).
    On any failure the temporary file is removed and ``path`` is left as it
    was; an ``OSError`` (disk full, read-only folder) becomes
    :class:`OutputWriteError`.
    """
    path = Path(path)
    fd, tmp = atomic_target(path)
    os.close(fd)
    try:
        write(tmp)
        seconds = os.environ.get("SCINTRACK_HOLD_BEFORE_RENAME") if hold else None
        if seconds:
            time.sleep(float(seconds))
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise write_failure(path, exc) from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_bytes(path: str | os.PathLike, data: str | bytes, *, fsync: bool = False, hold: bool = True) -> None:
    """Write ``data`` (text as UTF-8) to ``path`` atomically; ``fsync`` before the rename if asked; ``hold``: see :func:`atomic_write`."""
    payload = data.encode() if isinstance(data, str) else bytes(data)

    def write(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            fh.write(payload)
            if fsync:
                fh.flush()
                os.fsync(fh.fileno())

    atomic_write(path, write, hold=hold)


def writer_gone(name: str) -> bool:
    """Whether the process named in a temporary file's name (this host only) no longer runs."""
    stem = name[: -len(SUFFIX)]
    parts = stem.rsplit(".", 2)
    if len(parts) != 3 or "-" not in parts[1]:
        return False
    host, _, pid = parts[1].rpartition("-")
    if host != host_name() or not pid.isdigit():
        return False
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return True
    except PermissionError:
        return False
    return False


def clean_stale(roots: Iterable[str | os.PathLike]) -> list[Path]:
    """Remove the temporary files of dead writers under ``roots``; return what was removed."""
    removed = []
    for root in map(Path, roots):
        if not root.is_dir():
            continue
        for tmp in root.rglob(f".*{SUFFIX}"):
            if tmp.is_file() and writer_gone(tmp.name):
                tmp.unlink(missing_ok=True)
                removed.append(tmp)
    return removed
