"""Logging for workflow scripts: messages and warnings go to the rule's log file;
an uncaught :class:`scintrack.errors.InputError` becomes one ``error:`` line
(:func:`scintrack.errors.install_script_hook`).  A workflow job starts with
:func:`scintrack.jobcode.begin`, which calls :func:`setup`."""

from __future__ import annotations

import logging
import os
import sys
from pathlib import Path

from . import errors, profiling


def setup(log_path: str | None, name: str) -> logging.Logger:
    """A logger writing to ``log_path`` (and stderr); Python warnings are captured.

    Also the hook of the opt-in job profiler (:mod:`scintrack.profiling`).
    """
    profiling.start(name)
    logger = logging.getLogger(name)
    logger.setLevel(logging.INFO)
    logger.handlers.clear()
    fmt = logging.Formatter("%(levelname)s %(name)s: %(message)s")
    if log_path:
        Path(log_path).parent.mkdir(parents=True, exist_ok=True)
        fh = logging.FileHandler(log_path, mode="w")
        fh.setFormatter(fmt)
        logger.addHandler(fh)
        logging.captureWarnings(True)
        logging.getLogger("py.warnings").addHandler(fh)
    sh = logging.StreamHandler(sys.stderr)
    sh.setFormatter(fmt)
    sh.setLevel(logging.WARNING)
    logger.addHandler(sh)
    errors.install_script_hook(lambda line: _to_log_file(logger, line))
    # the allocator setting the job runs with (the Snakefile sets it for every job; docs/performance.md)
    logger.info("GLIBC_TUNABLES=%s", os.environ.get("GLIBC_TUNABLES", "(unset)"))
    return logger


def _to_log_file(logger: logging.Logger, line: str) -> None:
    """``line`` as an ERROR record in the log file only (stderr gets it once, from the hook)."""
    record = logger.makeRecord(logger.name, logging.ERROR, "", 0, line, None, None)
    for handler in logger.handlers:
        if isinstance(handler, logging.FileHandler):
            handler.handle(record)
