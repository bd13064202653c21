"""Table rule entry point: call one registered table function on its result files.

The function (found through :mod:`scintrack.products`) returns
``{stem: (DataFrame, title, note)}``; each stem is written to the rule's
``<stem>_csv`` and ``<stem>_md`` outputs.
"""

from scintrack import jobcode
from scintrack.experiments.guards import divergence_note
from scintrack.io import open_dataset
from scintrack.products import get
from scintrack.products.tables.common import join_notes, write_table

sm = snakemake  # noqa: F821
product = get(sm.params.product, sm.params.module)
log = jobcode.begin(sm, product.name)
inputs = [open_dataset(path, lazy=True) for path in sm.input]  # only the variables tabulated are read
tables = product.function(*inputs)
guard_note = divergence_note(inputs)  # diverged trials / non-estimable S4 of the tracking results read (guards)
missing = {k for k in sm.output.keys()} - {f"{s}_{e}" for s in tables for e in ("csv", "md")}
if missing:
    raise RuntimeError(f"{product.name}: the table function did not produce {sorted(missing)}")
written = []
for stem, (frame, title, note) in tables.items():
    written += write_table(frame, sm.output[f"{stem}_csv"], sm.output[f"{stem}_md"], title=title, note=join_notes(note, guard_note))
log.info("wrote %s", ", ".join(map(str, written)))
