"""Progress lines for long jobs: work done, rate and ETA, written to the job's log.

A :class:`Progress` counts units of work (filter-epochs of a shard, cells of
a table, ...) and logs ``label: done/total unit (pct), rate unit/s, ETA`` at
most every ``every_s`` seconds, and always when the work is complete::

    prog = Progress(total=trials * epochs * trackers, unit="filter-epochs", log=log.info)
    ...
    prog.add(trials * epochs, note="pll")

Logging only; it never changes a result.
"""

from __future__ import annotations

import time
from collections.abc import Callable


def _si(x: float) -> str:
    for div, suffix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if abs(x) >= div:
            return f"{x / div:.3g}{suffix}"
    return f"{x:.3g}"


def _duration(s: float) -> str:
    s = max(float(s), 0.0)
    if s < 60:
        return f"{s:.0f} s"
    if s < 3600:
        return f"{s // 60:.0f} min {s % 60:.0f} s"
    return f"{s // 3600:.0f} h {(s % 3600) // 60:.0f} min"


class Progress:
    """Work counter that logs rate and ETA (see the module docstring)."""

    def __init__(self, total: float, *, unit: str, log: Callable[[str], object] | None, label: str = "progress",
                 every_s: float = 10.0, clock: Callable[[], float] = time.monotonic):
        self.total = float(total)
        self.unit = unit
        self.log = log
        self.label = label
        self.every_s = float(every_s)
        self.clock = clock
        self.done = 0.0
        self.start = clock()
        self._last = -float("inf")

    def line(self, note: str = "") -> str:
        """The progress line for the current count."""
        elapsed = max(self.clock() - self.start, 1e-9)
        rate = self.done / elapsed
        pct = 100.0 * self.done / self.total if self.total > 0 else 100.0
        eta = (self.total - self.done) / rate if rate > 0 else float("inf")
        eta_s = "done" if self.done >= self.total else (f"ETA {_duration(eta)}" if eta != float("inf") else "ETA unknown")
        extra = f" [{note}]" if note else ""
        return (f"{self.label}: {_si(self.done)}/{_si(self.total)} {self.unit} ({pct:.0f}%), "
                f"{_si(rate)} {self.unit}/s, {_duration(elapsed)} elapsed, {eta_s}{extra}")

    def add(self, amount: float, note: str = "") -> None:
        """Count ``amount`` more units; log if ``every_s`` has passed since the last line or the work is complete."""
        self.done += float(amount)
        now = self.clock()
        if self.log is not None and (now - self._last >= self.every_s or self.done >= self.total):
            self._last = now
            self.log(self.line(note))
