"""Publication rule entry point: the paper-vs-reproduced page."""

from scintrack import jobcode
from scintrack.archive.compare import collect, render, summary
from scintrack.io import write_text

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "compare")
df = collect(sm.input, sm.params.tables)
md, page = render(df, {t: [tuple(f) for f in figs] for t, figs in sm.params.figures.items()})
write_text(md, sm.output.md)
write_text(page, sm.output.html)
log.info("%s", summary(df))
