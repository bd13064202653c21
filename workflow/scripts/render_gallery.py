"""Gallery rule entry point: figures/index.md and index.html from every figure's record (scintrack.products.gallery)."""

from scintrack import jobcode
from scintrack.products.gallery import render_gallery

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "gallery")
render_gallery(sm.input.records, sm.output.md, sm.output.html)
log.info("gallery of %d figures", len(sm.input.records))
