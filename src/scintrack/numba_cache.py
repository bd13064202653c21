"""Where numba keeps the package's compiled kernels: a folder per version of the source.

numba's own cache (``cache=True``) is checked against the timestamp of the
file that defines each kernel only.  Our kernels inline shared blocks from
other modules (``trackers/blocks.py``, ``estimators``, ...), so after an
edit of a block numba would keep running the kernel compiled from the old
block: a result that does not follow the code.  :func:`configure` points
``NUMBA_CACHE_DIR`` at ``<root>/<sha256 of every source file of the
package>/`` (16 hex digits), so any edit of the package starts from an empty
cache (one compilation, then cached again); unchanged code keeps its cache.
``<root>`` is ``$SCINTRACK_NUMBA_CACHE_ROOT``, else ``~/.cache/scintrack/numba``.
A ``NUMBA_CACHE_DIR`` already set by the user is left alone.

Hashing the bytes of the package's ~150 files takes a few milliseconds; it
runs once, when :mod:`scintrack` is imported (before any module imports numba).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

PACKAGE_ROOT = Path(__file__).resolve().parent


def source_fingerprint(root: Path = PACKAGE_ROOT) -> str:
    """sha256 (16 hex) of the relative path and bytes of every ``.py`` file under ``root``."""
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()[:16]


def cache_dir() -> Path:
    root = os.environ.get("SCINTRACK_NUMBA_CACHE_ROOT") or str(Path.home() / ".cache" / "scintrack" / "numba")
    return Path(root) / source_fingerprint()


def configure() -> None:
    """Set ``NUMBA_CACHE_DIR`` for this process (see the module docstring), unless the user set it."""
    if "NUMBA_CACHE_DIR" not in os.environ:
        os.environ["NUMBA_CACHE_DIR"] = str(cache_dir())
