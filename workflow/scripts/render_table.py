"""Table rule entry point: call one table function on its result files.

The function returns ``{stem: (DataFrame, title, note)}``; each stem is
written to the rule's ``<stem>_csv`` and ``<stem>_md`` outputs.
"""

import importlib
from pathlib import Path

from scintrack import runlog
from scintrack.figures.common import update_checksums
from scintrack.io import open_dataset
from scintrack.tables.common import write_table

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], sm.params.function)
func = getattr(importlib.import_module(sm.params.module), sm.params.function)
tables = func(*(open_dataset(path) for path in sm.input))
written = []
for stem, (frame, title, note) in tables.items():
    written += write_table(frame, sm.output[f"{stem}_csv"], sm.output[f"{stem}_md"], title=title, note=note)
missing = {k for k in sm.output.keys()} - {f"{s}_{e}" for s in tables for e in ("csv", "md")}
if missing:
    raise SystemExit(f"{sm.params.function} did not produce {sorted(missing)}")
update_checksums(Path(written[0]).parent.parent, written)
log.info("wrote %s", ", ".join(map(str, written)))
