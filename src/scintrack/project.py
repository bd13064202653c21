"""Where a project file named in the config is: in the working directory, else in the repository.

A config names files by paths relative to the project (``data/registry.yaml``,
``data/ephemerides/brdc2800.15n``); a run with ``--directory`` elsewhere (the
test suite) still reads the project's tracked copies.  The relative name is
what enters params and versions, so they do not depend on where the
repository is checked out.
"""

from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def project_file(path: str | Path) -> Path:
    """``path`` if absolute or present under the working directory, else under the repository."""
    p = Path(path)
    if p.is_absolute() or p.exists():
        return p
    return REPO / p
