"""Deterministic figure output and the ``SHA256SUMS`` manifest beside figures.

Figures are saved as PDF and PNG with fixed metadata (no dates, no software
stamp), so the same inputs in the locked environment give the same bytes.
:func:`update_checksums` rewrites the entries of the files just rendered in
the folder's ``SHA256SUMS`` under an exclusive lock, so two rules rendering
at once never lose each other's lines.
"""

from __future__ import annotations

import fcntl
import os
from collections.abc import Iterable
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

from ..io import sha256_file, write_text  # noqa: E402

STYLE = {
    "figure.dpi": 100,
    "savefig.dpi": 150,
    "font.size": 9,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "legend.fontsize": 8,
    "svg.hashsalt": "scintrack",
    "path.simplify": False,
}

PDF_METADATA = {"CreationDate": None, "ModDate": None, "Producer": None, "Creator": "scintrack"}
PNG_METADATA = {"Software": None}


def new_figure(nrows: int = 2, ncols: int = 1, *, figsize=(6.4, 6.0), **kwargs):
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(nrows, ncols, figsize=figsize, **kwargs)
    return fig, axes


def save_figure(fig, paths: Iterable[str | os.PathLike]) -> list[Path]:
    """Save ``fig`` to every path (format from the suffix), atomically; close it."""
    written = []
    with plt.rc_context(STYLE):
        for path in map(Path, paths):
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(f".{path.name}.part")
            fmt = path.suffix.lstrip(".")
            meta = PDF_METADATA if fmt == "pdf" else PNG_METADATA if fmt == "png" else None
            fig.savefig(tmp, format=fmt, metadata=meta)
            os.replace(tmp, path)
            written.append(path)
    plt.close(fig)
    return written


def read_checksums(path: Path) -> dict[str, str]:
    sums = {}
    if path.exists():
        for line in path.read_text().splitlines():
            if line.strip():
                digest, name = line.split(maxsplit=1)
                sums[name.lstrip("*")] = digest
    return sums


def update_checksums(folder: str | os.PathLike, files: Iterable[str | os.PathLike]) -> Path:
    """Set the ``sha256sum``-format entries of ``files`` in ``folder/SHA256SUMS``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    sums_path = folder / "SHA256SUMS"
    lock_path = folder / ".SHA256SUMS.lock"
    with open(lock_path, "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        sums = read_checksums(sums_path)
        for f in map(Path, files):
            sums[f.resolve().relative_to(folder.resolve()).as_posix()] = sha256_file(f)
        write_text("".join(f"{sums[k]}  {k}\n" for k in sorted(sums)), sums_path)
    return sums_path
