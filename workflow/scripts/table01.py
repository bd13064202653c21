"""Table rule entry point: Table I (AR orders) and its paper-vs-reproduced twin."""

from pathlib import Path

from scintrack import runlog
from scintrack.figures.common import update_checksums
from scintrack.io import open_dataset
from scintrack.tables.common import write_table
from scintrack.tables.vila_valls_2018 import table01_by_length, table01_long, table01_twin

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], "table01")
lut = open_dataset(sm.input.lut)
long = table01_long(lut)
twin = table01_twin(long)
n = int(lut.sizes["trial"])
note = (
    f"Orders selected on {n} CSM realisations per (S4, tau0) grid point "
    f"({float(lut.attrs.get('ts', 0.01)) * 1000:g} ms samples); PACF rule: first lag inside the "
    f"{100 * (1 - float(lut.attrs['pacf_alpha'])):g}% band, minus one. Cells: modal order [share of fits; range]."
)
written = write_table(long, sm.output.csv, sm.output.md, title="Table I (reproduced): AR model orders per scintillation region", note=note)
written += write_table(twin, sm.output.twin_csv, sm.output.twin_md, title="Table I: paper vs reproduced", note=note)
written += write_table(
    table01_by_length(lut), sm.output.length_csv, sm.output.length_md,
    title="Table I supplement: PACF-rule order against the length of the series",
    note="Same realisations, PACF computed on the first L seconds only; the 95% band is +-1.96/sqrt(N).",
)
update_checksums(Path(sm.output.csv).parent.parent, written)
log.info("table I over %d S4 values", lut.sizes["s4"])
