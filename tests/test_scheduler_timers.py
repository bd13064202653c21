"""The Snakefile's onsuccess/onerror cancel the scheduler's pending timers (scintrack.pipeline.scheduler_timers)."""

from __future__ import annotations

import re
import threading

from conftest import REPO

from scintrack.pipeline.scheduler_timers import cancel_pending


def test_pending_timers_are_cancelled_and_their_threads_end():
    fired = []
    timers = [threading.Timer(60.0, fired.append, args=(i,)) for i in range(3)]
    for t in timers:
        t.start()
    other = threading.Thread(target=threading.Event().wait, args=(0.2,))
    other.start()
    assert cancel_pending() >= 3
    for t in timers:
        t.join(timeout=5.0)
        assert not t.is_alive()
    other.join()
    assert fired == []  # cancelled, not fired


def test_the_snakefile_cancels_them_on_success_and_on_error():
    text = (REPO / "Snakefile").read_text()
    for hook in ("onsuccess", "onerror"):
        block = re.search(rf"^{hook}:\n((?:    .*\n|\n)+)", text, re.M)
        assert block and "cancel_pending()" in block.group(1), hook
