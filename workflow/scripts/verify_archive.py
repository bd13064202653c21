"""Publication rule entry point: verify the bundle against itself and the regenerated results."""

import sys

from scintrack import jobcode
from scintrack.archive.verify import verify
from scintrack.io import write_text

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "verify")
problems = verify(sm.input[0], against=".")
for line in problems:
    log.error("%s", line)
    print(line, file=sys.stderr)
if problems:
    sys.exit(f"verify: {len(problems)} problem(s) in {sm.input[0]}")
write_text(f"OK {sm.input[0]}: every checksum matches; regenerated results reproduce the archived content hashes\n", sm.output[0])
