"""Fetching real traces: a local HTTP server on 127.0.0.1 serves the file.

Checked: a good transfer verifies; a corrupted copy is rejected and moved
aside; a truncated transfer leaves nothing at the final path and a retry
resumes it (HTTP Range); no checksum fails unless trust on first use is asked
for, which records the sha256 in the registry.
"""

from __future__ import annotations

import hashlib
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from scintrack.data.download import FetchError, fetch
from scintrack.data.registry import expected_sha256, record_sha256

PAYLOAD = bytes(range(256)) * 4096  # 1 MiB
SHA = hashlib.sha256(PAYLOAD).hexdigest()


class Handler(BaseHTTPRequestHandler):
    body = PAYLOAD
    cut_at: int | None = None  # announce the full length but stop sending here
    ranges_seen: list = []

    def do_GET(self):  # noqa: N802 (http.server API)
        start = 0
        rng = self.headers.get("Range")
        if rng:
            type(self).ranges_seen.append(rng)
            start = int(rng.split("=")[1].split("-")[0])
            self.send_response(206)
            self.send_header("Content-Range", f"bytes {start}-{len(self.body) - 1}/{len(self.body)}")
        else:
            self.send_response(200)
        data = self.body[start:]
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        if self.cut_at is not None:
            self.wfile.write(data[: self.cut_at])
            self.wfile.flush()
            self.connection.close()
            return
        self.wfile.write(data)

    def log_message(self, *args):
        pass


@pytest.fixture
def server():
    Handler.body, Handler.cut_at, Handler.ranges_seen = PAYLOAD, None, []
    srv = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    thread = threading.Thread(target=srv.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{srv.server_address[1]}/event1.nc"
    srv.shutdown()
    srv.server_close()


def test_fetch_verifies_and_places_the_file(server, tmp_path):
    final = tmp_path / "raw" / "event1.nc"
    assert fetch({"url": server}, final, SHA) == SHA
    assert final.read_bytes() == PAYLOAD
    assert not list(final.parent.glob("*.part"))


def test_corrupted_copy_is_rejected_and_moved_aside(server, tmp_path):
    Handler.body = PAYLOAD[:-1] + b"\x00"
    final = tmp_path / "event1.nc"
    with pytest.raises(FetchError, match=f"sha256 mismatch: expected {SHA}, got [0-9a-f]{{64}}.*moved aside") as info:
        fetch({"url": server}, final, SHA)
    assert "event1.nc" in str(info.value)
    assert not final.exists()
    aside = list(tmp_path.glob("event1.nc.rejected-*"))
    assert len(aside) == 1 and aside[0].read_bytes() == Handler.body


def test_truncated_transfer_leaves_no_final_file_and_a_retry_resumes(server, tmp_path):
    final = tmp_path / "event1.nc"
    Handler.cut_at = 300_000
    with pytest.raises(FetchError, match="truncated|transfer failed"):
        fetch({"url": server}, final, SHA)
    assert not final.exists()
    part = tmp_path / "event1.nc.part"
    assert part.exists() and 0 < part.stat().st_size < len(PAYLOAD)
    Handler.cut_at = None
    assert fetch({"url": server}, final, SHA) == SHA
    assert final.read_bytes() == PAYLOAD
    assert Handler.ranges_seen == ["bytes=300000-"]  # the retry asked only for the missing bytes


def test_unreachable_url_is_a_clear_error(tmp_path):
    with pytest.raises(FetchError, match="unreachable .*nothing was downloaded") as info:
        fetch({"url": "http://127.0.0.1:9/none.nc"}, tmp_path / "x.nc", SHA, timeout=2)
    assert ".part" not in str(info.value)  # no partial file is claimed (none exists)
    assert not list(tmp_path.iterdir())


def test_local_path_and_missing_checksum(tmp_path):
    src = tmp_path / "mirror.nc"
    src.write_bytes(PAYLOAD)
    with pytest.raises(FetchError, match="no sha256 in the registry"):
        fetch({"path": str(src)}, tmp_path / "out" / "a.nc", None)
    assert not (tmp_path / "out" / "a.nc").exists()
    assert fetch({"path": str(src)}, tmp_path / "out" / "a.nc", None, trust_on_first_use=True) == SHA
    registry = tmp_path / "registry.yaml"
    record_sha256(registry, "jrc_hanoi_event1", SHA, "trust on first use")
    assert expected_sha256(registry, "jrc_hanoi_event1") == SHA
