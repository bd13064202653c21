"""Where numba keeps the package's compiled kernels, and how a damaged entry is kept from being loaded.

**A folder per version of the source.**  numba's own cache (``cache=True``)
is checked against the timestamp of the file that defines each kernel only.
Our kernels inline shared blocks from other modules (``trackers/blocks.py``,
``estimators``, ...), so after an edit of a block numba would keep running
the kernel compiled from the old block: a result that does not follow the
code.  The project's cache folder is ``<root>/<sha256 of every source file
of the package>/`` (16 hex digits), so any edit of the package starts from an
empty cache (one compilation, then cached again); unchanged code keeps its
cache.  ``<root>`` is ``$SCINTRACK_NUMBA_CACHE_ROOT``, else
``~/.cache/scintrack/numba``.  A ``NUMBA_CACHE_DIR`` set by the user (not by
a scintrack parent process) is left alone, and so is the folder it names.

**Checked before numba reads it.**  numba loads a cache entry (an index
``.nbi`` and its data files ``.nbc``) without any check: a truncated or
garbled file fails the job with numba's traceback, and a flipped bit in the
machine code can crash the process.  So the folder holds ``SHA256SUMS``
(``sha256sum -c`` format) of every cache file, and :func:`configure` (run
when :mod:`scintrack` is imported, before any module imports numba) checks
every cache file against it.  A kernel's entry with any file that is not
listed, differs from its checksum, or is listed but missing is deleted
whole; numba then compiles that kernel again, and one ``warning:`` line names
the folder.  If the folder cannot be cleaned or written, one ``error:`` line
names it and says to delete it, and the process exits with status 1.

**Each process works in a copy of the checked files.**  numba is pointed
(``NUMBA_CACHE_DIR``) at a working folder of this process inside the cache
folder, ``.numba-work.<host>-<pid>.<random>.scintrack-tmp``, filled with
hard links to the checked files (copies where the file system has no hard
links).  numba writes a new entry there (temporary file, then rename), never
into a file of the shared folder.  When the process ends normally (atexit),
:meth:`Workspace.publish` copies every entry it compiled into the shared
folder, each file atomically, the whole entry replacing the old one, and adds
their checksums to ``SHA256SUMS`` (temporary file, then rename), under an
exclusive ``flock`` of ``.scintrack-numba.lock`` that the check at start-up
takes too.  So two jobs that share the folder (``snakemake --cores 2``):

* never load a file that no checksum covers: an entry another job wrote
  after this one started is not in this job's working folder, and a file
  found in the shared folder without a checksum (its writer was killed before
  it published, or the file was put there by hand) is deleted, not trusted;
* never lose each other's checksums: each publication re-reads
  ``SHA256SUMS`` under the lock and changes only the entries it publishes;
* never see half an entry: a check and a publication never overlap.

The cost of that choice: a kernel compiled by a job that is still running is
compiled again by a job that starts meanwhile, and the kernels of a killed
job are compiled again by the next one.  The working folder of a process that
no longer runs (same host) is removed by the next start-up.

Cost at import: hashing the package's ~150 source files takes about 5 ms;
checking a complete cache of the package (about 400 files, 15 MB: mostly
the hashing) and linking it into the working folder about 25 ms.  The exit
hook of a process that compiled nothing takes about 6 ms.
"""

from __future__ import annotations

import atexit
import fcntl
import hashlib
import os
import shutil
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from .atomic import SUFFIX, host_name, writer_gone, atomic_bytes
from .checksums import read_checksums
from .errors import PREFIX, InputError, one_line
from .io import sha256_file

PACKAGE_ROOT = Path(__file__).resolve().parent
MANIFEST = "SHA256SUMS"
LOCK = ".scintrack-numba.lock"
WORK_PREFIX = ".numba-work."
CACHE_SUFFIXES = (".nbi", ".nbc")
#: the working folder this package set as ``NUMBA_CACHE_DIR`` (so a child process knows the value is not the user's)
MARK = "SCINTRACK_NUMBA_WORK_DIR"


class NumbaCacheError(InputError):
    """The numba cache folder cannot be cleaned or written; the message names it and says to delete it."""


def source_fingerprint(root: Path = PACKAGE_ROOT) -> str:
    """sha256 (16 hex) of the relative path and bytes of every ``.py`` file under ``root``."""
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()[:16]


def cache_dir() -> Path:
    """The project's cache folder for the current source (absolute: numba may be used after a change of directory)."""
    root = os.environ.get("SCINTRACK_NUMBA_CACHE_ROOT") or str(Path.home() / ".cache" / "scintrack" / "numba")
    return Path(root).absolute() / source_fingerprint()


def entry_of(rel: str) -> str:
    """The cache entry a cache file belongs to: ``K.nbi`` and ``K.<n>.nbc`` are entry ``K`` (one kernel)."""
    stem = rel[:-4]
    if rel.endswith(".nbc"):
        head, _, number = stem.rpartition(".")
        if head and number.isdigit():
            return head
    return stem


def _is_work(name: str) -> bool:
    return name.startswith(WORK_PREFIX) and name.endswith(SUFFIX)


def _scan(folder: Path, suffixes: tuple[str, ...] = CACHE_SUFFIXES) -> dict[str, os.DirEntry]:
    """Every file under ``folder`` whose name ends with one of ``suffixes``, by its relative path, the working folders left out."""
    found, stack = {}, [("", str(folder))]
    while stack:
        prefix, path = stack.pop()
        try:
            entries = list(os.scandir(path))
        except FileNotFoundError:
            continue
        for entry in entries:
            if entry.is_dir(follow_symlinks=False):
                if prefix or not _is_work(entry.name):
                    stack.append((prefix + entry.name + "/", entry.path))
            elif entry.name.endswith(suffixes):
                found[prefix + entry.name] = entry
    return found


def cache_files(folder: Path) -> dict[str, Path]:
    """Every ``.nbi``/``.nbc`` file under ``folder`` by its relative path, the working folders left out."""
    return {rel: Path(entry.path) for rel, entry in _scan(folder).items()}


def read_manifest(folder: Path) -> tuple[dict[str, str], bool]:
    """(``SHA256SUMS`` of ``folder``, whether it could be read); an unreadable one counts as empty."""
    try:
        return read_checksums(folder / MANIFEST), True
    except (OSError, ValueError):  # garbled: not UTF-8, a line without a name
        return {}, False


def write_manifest(folder: Path, sums: dict[str, str]) -> None:
    atomic_bytes(folder / MANIFEST, "".join(f"{sums[k]}  {k}\n" for k in sorted(sums)), hold=False)


@contextmanager
def locked(folder: Path) -> Iterator[None]:
    """Hold the exclusive lock of ``folder`` (created if missing) for the ``with`` block."""
    folder.mkdir(parents=True, exist_ok=True)
    fd = os.open(folder / LOCK, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


def _link_all(files: dict[str, os.DirEntry], dst: Path) -> None:
    """Hard-link every file of ``files`` (relative path -> entry) into ``dst`` (a copy where the file system has no hard links)."""
    made = set()
    for rel, entry in files.items():
        folder, _, _ = rel.rpartition("/")
        if folder not in made:
            os.makedirs(dst / folder, exist_ok=True)
            made.add(folder)
        try:
            os.link(entry.path, dst / rel)
        except OSError:
            shutil.copyfile(entry.path, dst / rel)


class Workspace:
    """A process's working folder ``work`` inside the cache ``folder``, filled with the checked cache files."""

    def __init__(self, folder: Path, work: Path, removed: int = 0, entries: int = 0) -> None:
        self.folder, self.work = folder, work
        self.removed = removed  # damaged or unlisted files deleted at start
        self.entries = entries  # kernels they belonged to (or whose listed files were missing)
        self.linked: dict[str, int] = {}  # file -> its inode as linked at start
        self.pid = os.getpid()

    def warning(self) -> str | None:
        """The one warning line of the check at start-up, if it deleted anything."""
        if not self.entries:
            return None
        return (f"numba cache {self.folder}: {self.entries} kernel(s) had damaged, missing or unlisted files "
                f"({self.removed} deleted); numba compiles them again")

    def compiled(self) -> dict[str, Path]:
        """The files of every entry that numba wrote in the working folder (whole entries)."""
        files = _scan(self.work)  # numba replaces a file it writes (new inode), never writes into one
        changed = {entry_of(rel) for rel, entry in files.items() if self.linked.get(rel) != entry.inode()}
        return {rel: Path(entry.path) for rel, entry in files.items() if entry_of(rel) in changed}

    def publish(self) -> int:
        """Copy the entries numba compiled into the shared folder and list their checksums; return the files copied."""
        files = self.compiled()
        if not files:
            return 0
        entries = {entry_of(rel) for rel in files}
        with locked(self.folder):
            sums, _ = read_manifest(self.folder)  # unreadable: the other entries are unlisted, so checked away next time
            for rel, path in cache_files(self.folder).items():  # the old files of a replaced entry go
                if entry_of(rel) in entries and rel not in files:
                    path.unlink(missing_ok=True)
                    sums.pop(rel, None)
            for rel, path in sorted(files.items()):
                data = path.read_bytes()
                atomic_bytes(self.folder / rel, data, hold=False)
                sums[rel] = hashlib.sha256(data).hexdigest()
            write_manifest(self.folder, sums)
        return len(files)

    def close(self) -> None:
        """At exit: publish, then remove the working folder; a failure is one ``warning:`` line, never an error."""
        if os.getpid() != self.pid:  # a forked child that exits normally is not the owner
            return
        try:
            self.publish()
        except (OSError, InputError) as exc:
            reason = one_line(getattr(exc, "strerror", None) or exc)
            print(f"warning: numba cache {self.folder}: the kernels compiled by this process were not saved ({reason}); "
                  "they compile again next time", file=sys.stderr, flush=True)
        finally:
            shutil.rmtree(self.work, ignore_errors=True)


def check(folder: Path) -> Workspace:
    """Check ``folder`` against its ``SHA256SUMS``, delete damaged entries, and make this process's working folder.

    Raises :class:`NumbaCacheError` if the folder cannot be cleaned or written.
    """
    try:
        with locked(folder):
            for entry in folder.iterdir():  # working folders of processes that no longer run
                if _is_work(entry.name) and entry.is_dir() and writer_gone(entry.name):
                    shutil.rmtree(entry, ignore_errors=True)
            found = _scan(folder, (*CACHE_SUFFIXES, SUFFIX))
            for rel, entry in found.items():  # temporary files of a publication that was killed
                if rel.endswith(SUFFIX) and writer_gone(entry.name):
                    os.unlink(entry.path)
            sums, readable = read_manifest(folder)
            files = {rel: Path(entry.path) for rel, entry in found.items() if rel.endswith(CACHE_SUFFIXES)}
            digests = {rel: sha256_file(path) for rel, path in files.items()}
            bad = {entry_of(rel) for rel, digest in digests.items() if sums.get(rel) != digest}
            bad |= {entry_of(rel) for rel in sums if rel not in digests}
            keep = {rel: digest for rel, digest in digests.items() if entry_of(rel) not in bad}
            removed = 0
            for rel in sorted(files):
                if entry_of(rel) in bad:
                    files[rel].unlink()
                    removed += 1
            if keep != sums or not readable:
                write_manifest(folder, keep)
            work = Path(tempfile.mkdtemp(prefix=f"{WORK_PREFIX}{host_name()}-{os.getpid()}.", suffix=SUFFIX, dir=folder))
            space = Workspace(folder, work, removed=removed, entries=len(bad))
            try:
                _link_all({rel: found[rel] for rel in keep}, work)
                space.linked = {rel: entry.inode() for rel, entry in _scan(work).items()}  # as compiled() will see them
            except BaseException:
                shutil.rmtree(work, ignore_errors=True)
                raise
    except (OSError, InputError) as exc:
        reason = one_line(getattr(exc, "strerror", None) or exc)
        raise NumbaCacheError(f"numba cache folder {folder} cannot be cleaned or written ({reason}); delete it "
                              f"(rm -rf '{folder}') or make it writable, or set SCINTRACK_NUMBA_CACHE_ROOT to a folder "
                              "you can write, then rerun") from None
    return space


_workspace: Workspace | None = None


def configure() -> Workspace | None:
    """Check the project's cache folder and point ``NUMBA_CACHE_DIR`` at this process's working folder (module docstring).

    Does nothing if the user set ``NUMBA_CACHE_DIR``, or if it already ran in
    this process.  A folder that cannot be cleaned or written ends the process
    with one ``error:`` line (status 1): this runs at import, before any
    handler that would print an :class:`~scintrack.errors.InputError` so.
    """
    global _workspace
    current = os.environ.get("NUMBA_CACHE_DIR")
    if _workspace is not None or (current and current != os.environ.get(MARK)):
        return _workspace
    try:
        space = check(cache_dir())
    except NumbaCacheError as exc:
        sys.exit(PREFIX + one_line(exc))
    if (line := space.warning()) is not None:
        print("warning: " + line, file=sys.stderr, flush=True)
    os.environ["NUMBA_CACHE_DIR"] = os.environ[MARK] = str(space.work)
    atexit.register(space.close)
    _workspace = space
    return space
