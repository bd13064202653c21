"""The project's error type for bad input, and how a workflow script reports it.

:class:`InputError` is raised for anything the user can fix: a config value,
a missing, truncated or malformed file, a wrong checksum, an unreachable
source.  Its message is one line that names the file or setting and the fix.
The specific kinds (:class:`ConfigError` here,
:class:`scintrack.data.traces.TraceFormatError`,
:class:`scintrack.data.download.FetchError`, ...) derive from it, so a caller
that only wants to know "is this the user's input?" catches ``InputError``.

:func:`install_script_hook` (called by :func:`scintrack.runlog.setup`, so by
every workflow script) turns an uncaught ``InputError`` into that one line on
stderr prefixed ``error:``, the same line in the job's log, and exit status 1,
with no Python traceback: the traceback of a user's mistake only hides the
line that says what to change.  Every other exception keeps its traceback
(it is a bug, and the traceback is what a developer needs).
"""

from __future__ import annotations

import sys
from collections.abc import Callable

PREFIX = "error: "


class InputError(ValueError):
    """Bad input the user can fix; the message is one line naming the file or setting and the fix."""


class ConfigError(InputError):
    """A configuration value is invalid; the message is one line."""


def one_line(message: object) -> str:
    """``message`` on one line (newlines and runs of blanks folded into single spaces)."""
    return " ".join(str(message).split())


def install_script_hook(log: Callable[[str], object] | None = None) -> None:
    """Report an uncaught :class:`InputError` as one ``error:`` line (and ``log`` it), exit status 1."""
    previous = sys.excepthook

    def hook(kind, value, tb):
        if isinstance(value, InputError):
            line = one_line(value)
            if log is not None:
                try:
                    log(line)
                except Exception:  # noqa: BLE001 (the line on stderr matters more than the log)
                    pass
            print(PREFIX + line, file=sys.stderr, flush=True)
            sys.exit(1)
        previous(kind, value, tb)

    sys.excepthook = hook
