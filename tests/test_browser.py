"""The gallery and the comparison page opened in a real browser (headless Chromium).

The smoke build's ``figures/index.html`` and ``tables/compare.html`` are
served on localhost and loaded, each inside a same-origin harness page, at a
phone's width: every image must have loaded (decoded, non-zero width), every
in-page link must reach its anchor, the page must not need sideways
scrolling, the server must have answered every request, and the browser must
have logged nothing from the page.  A screenshot of each page is kept in
``logs/browser/`` (``SCINTRACK_SCREENSHOTS`` overrides the folder).

Chromium comes from the system (``.ci/run`` installs Debian's ``chromium``
when it is missing); without it the test is skipped, unless
``SCINTRACK_REQUIRE_BROWSER=1`` (set by ``.ci/run``) makes that a failure.
"""

from __future__ import annotations

import functools
import http.server
import json
import os
import re
import shutil
import subprocess
import threading
from pathlib import Path

import pytest
from conftest import REPO

pytestmark = pytest.mark.pipeline

PHONE = (412, 915)  # CSS pixels
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--hide-scrollbars", "--enable-logging=stderr", "--v=0"]

HARNESS = """<!DOCTYPE html><html><head><meta charset='utf-8'></head><body>
<iframe id='page' src='{src}' style='width:{w}px;height:{h}px;border:0'></iframe>
<script>
const frame = document.getElementById('page');
frame.addEventListener('load', () => {{
  const d = frame.contentDocument;
  const images = Array.from(d.images);
  const broken = images.filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.alt || i.src.slice(0, 60));
  const anchors = Array.from(d.querySelectorAll("a[href^='#']")).map(a => decodeURIComponent(a.getAttribute('href').slice(1)));
  const missing = anchors.filter(id => !d.getElementById(id));
  const wide = d.documentElement.scrollWidth > d.documentElement.clientWidth + 1;
  document.body.setAttribute('data-result', JSON.stringify({{images: images.length, broken, anchors: anchors.length, missing, wide}}));
}});
</script></body></html>"""


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    if os.environ.get("SCINTRACK_REQUIRE_BROWSER") == "1":
        pytest.fail("no Chromium on PATH (SCINTRACK_REQUIRE_BROWSER=1): install Debian's 'chromium' package (.ci/run does)")
    pytest.skip("no Chromium on PATH; install Debian's 'chromium' package to run the browser test")
    return None


class _Handler(http.server.SimpleHTTPRequestHandler):
    """Serves the build folder and the harness pages; records every status it answers."""

    def __init__(self, *args, harnesses, statuses, **kwargs):
        self.harnesses, self.statuses = harnesses, statuses
        super().__init__(*args, **kwargs)

    def do_GET(self):  # noqa: N802 (http.server's name)
        name = self.path.split("?")[0].lstrip("/")
        if name in self.harnesses:
            body = self.harnesses[name].encode()
            self.send_response(200)
            self.send_header("Content-Type", "text/html; charset=utf-8")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)
            return
        if name == "favicon.ico":  # asked for by the browser itself, not by a page
            self.send_response(204)
            self.end_headers()
            return
        super().do_GET()

    def log_request(self, code="-", size="-"):
        self.statuses.append((self.path, int(code) if str(code).isdigit() else 0))


@pytest.fixture(scope="module")
def served(smoke_run):
    pages = {"gallery": "figures/index.html", "compare": "tables/compare.html"}
    harnesses = {f"harness_{k}.html": HARNESS.format(src="/" + v, w=PHONE[0], h=PHONE[1]) for k, v in pages.items()}
    statuses: list[tuple[str, int]] = []
    handler = functools.partial(_Handler, harnesses=harnesses, statuses=statuses, directory=str(smoke_run))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}", pages, statuses
    server.shutdown()


def _browse(chromium: str, url: str, *extra: str, user_dir: Path) -> subprocess.CompletedProcess:
    cmd = [chromium, *FLAGS, f"--user-data-dir={user_dir}", *extra, url]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("page", ["gallery", "compare"])
def test_page_loads_in_a_real_browser_at_phone_width(served, page, tmp_path):
    chromium = _chromium()
    base, pages, statuses = served
    start = len(statuses)
    proc = _browse(chromium, f"{base}/harness_{page}.html", "--dump-dom", "--virtual-time-budget=20000",
                   f"--window-size={PHONE[0] + 40},{PHONE[1] + 40}", user_dir=tmp_path / "profile")
    assert proc.returncode == 0, proc.stderr[-2000:]
    found = re.search(r"data-result=\"([^\"]*)\"", proc.stdout)
    assert found, f"the harness never saw {pages[page]} load:\n{proc.stdout[-1500:]}"
    result = json.loads(found.group(1).replace("&quot;", '"').replace("&amp;", "&"))
    assert result["broken"] == [], f"{pages[page]}: images that did not load: {result['broken']}"
    assert result["missing"] == [], f"{pages[page]}: links to anchors that do not exist: {result['missing']}"
    assert not result["wide"], f"{pages[page]} needs sideways scrolling at {PHONE[0]} px"
    if page == "gallery":
        assert result["images"] >= 30
    console = [line for line in proc.stderr.splitlines() if "CONSOLE" in line]
    assert console == [], "the page logged:\n" + "\n".join(console)
    failed = [(path, code) for path, code in statuses[start:] if code >= 400]
    assert failed == [], f"requests that failed: {failed}"

    shots = Path(os.environ.get("SCINTRACK_SCREENSHOTS", REPO / "logs" / "browser"))
    shots.mkdir(parents=True, exist_ok=True)
    shot = shots / f"{page}_phone.png"
    proc = _browse(chromium, f"{base}/{pages[page]}", f"--screenshot={shot}", f"--window-size={PHONE[0]},{PHONE[1] * 3}",
                   user_dir=tmp_path / "profile2")
    assert proc.returncode == 0 and shot.stat().st_size > 10_000, proc.stderr[-2000:]
