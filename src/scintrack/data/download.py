"""Obtain an external file (URL or local path) and verify its sha256 before use.

Guarantees (``docs/data.md``):

* the file appears at its final path only complete and verified: bytes go to
  ``<final>.part`` and are renamed at the end;
* an interrupted or truncated HTTP transfer raises :class:`FetchError` and
  leaves no file at the final path; the ``.part`` file stays, and a retry
  resumes it with an HTTP Range request (or starts over when the server
  ignores ranges);
* a wrong checksum raises :class:`FetchError` naming the file, the expected
  and the actual sha256, and moves the bad bytes aside to
  ``<final>.rejected-<sha256[:12]>`` (kept for inspection, never used);
* with no expected sha256, the fetch fails unless trust on first use was asked
  for, in which case the observed sha256 is returned for the registry.
"""

from __future__ import annotations

import os
import shutil
import urllib.error
import urllib.request
from pathlib import Path

from ..errors import InputError
from ..io import sha256_file


class FetchError(InputError):
    """A source that could not be obtained or did not verify."""


def _http_fetch(url: str, part: Path, timeout: float) -> None:
    offset = part.stat().st_size if part.exists() else 0
    request = urllib.request.Request(url)
    if offset:
        request.add_header("Range", f"bytes={offset}-")
    try:
        with urllib.request.urlopen(request, timeout=timeout) as resp:
            status = getattr(resp, "status", 200)
            if offset and status != 206:  # server ignored the range: start over
                offset = 0
            total = resp.headers.get("Content-Length")
            expected = int(total) + offset if total is not None else None
            with open(part, "ab" if offset else "wb") as fh:
                shutil.copyfileobj(resp, fh, 1 << 20)
    except urllib.error.HTTPError as exc:
        raise FetchError(f"{url}: HTTP {exc.code} {exc.reason}; check real_traces.sources in the config") from None
    except (urllib.error.URLError, OSError, TimeoutError) as exc:
        reason = getattr(exc, "reason", exc)
        kept = part.stat().st_size if part.exists() else 0
        if kept:
            raise FetchError(f"{url}: transfer failed ({reason}); partial data ({kept} bytes) kept in {part} and resumed on retry") from None
        part.unlink(missing_ok=True)
        raise FetchError(f"{url}: unreachable ({reason}), nothing was downloaded; check the URL in real_traces.sources and the network, "
                         "or give a local 'path'") from None
    size = part.stat().st_size
    if expected is not None and size < expected:
        raise FetchError(f"{url}: transfer truncated ({size} of {expected} bytes); partial data kept in {part} and resumed on retry")


def fetch(source: dict, final: str | Path, expected_sha256: str | None, *, trust_on_first_use: bool = False, timeout: float = 60.0,
          registry: str | Path = "data/registry.yaml") -> str:
    """Obtain ``source`` ({url: ...} or {path: ...}) at ``final``; return its sha256 (``registry``: named in the error when it has none)."""
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    part = final.with_name(final.name + ".part")
    if "url" in source:
        url = str(source["url"])
        if url.startswith("file://"):
            src = Path(urllib.request.url2pathname(url[7:]))
            _copy_local(src, part)
        elif url.startswith(("http://", "https://")):
            _http_fetch(url, part, timeout)
        else:
            raise FetchError(f"{url}: only http(s):// and file:// URLs are supported; or give a local 'path'")
    elif "path" in source:
        _copy_local(Path(os.path.expanduser(str(source["path"]))), part)
    else:
        raise FetchError(f"source {source!r} has neither 'url' nor 'path'")
    actual = sha256_file(part)
    if expected_sha256 is None:
        if not trust_on_first_use:
            part.unlink()
            raise FetchError(
                f"{final.name}: no sha256 in the registry; add it to {registry}, or set real_traces.trust_on_first_use: true to record {actual}"
            )
    elif actual != expected_sha256.lower():
        aside = final.with_name(f"{final.name}.rejected-{actual[:12]}")
        os.replace(part, aside)
        raise FetchError(f"{final.name}: sha256 mismatch: expected {expected_sha256}, got {actual}; the file was moved aside to {aside} and not used")
    os.replace(part, final)
    return actual


def _copy_local(src: Path, part: Path) -> None:
    if not src.is_file():
        raise FetchError(f"{src}: no such file; check real_traces.sources in the config")
    try:
        shutil.copyfile(src, part)
    except OSError as exc:
        part.unlink(missing_ok=True)
        side = "read" if not os.access(src, os.R_OK) else "write"
        where = src if side == "read" else part
        raise FetchError(f"{where}: could not {side} it ({exc.strerror or exc}); "
                         + ("fix its permissions" if side == "read" else f"free disk space or make {part.parent} writable, then rerun")) from None
