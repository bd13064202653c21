"""Data rule entry point: fetch one real trace and verify its sha256."""

import sys
from datetime import UTC, datetime

from scintrack import jobcode
from scintrack.data.download import fetch
from scintrack.data.registry import expected_sha256, record_sha256

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "fetch_trace")
expected = expected_sha256(sm.params.registry, sm.params.name)
actual = fetch(dict(sm.params.source), sm.output[0], expected, trust_on_first_use=bool(sm.params.tofu), registry=sm.params.registry)  # FetchError: one error: line
if expected is None:
    record_sha256(sm.params.registry, sm.params.name, actual, f"trust on first use, {datetime.now(UTC):%Y-%m-%d}")
    msg = f"trust on first use: recorded sha256 {actual} for {sm.params.name} in {sm.params.registry}"
    log.warning("%s", msg)
    print(msg, file=sys.stderr)
log.info("%s verified (sha256 %s)", sm.output[0], actual)
