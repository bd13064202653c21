"""Figure rule entry point: call one registered figure function on its result files.

``params.product`` names the rule; :mod:`scintrack.products` holds the
function it was declared on (the link from a figure to the code that drew
it).  Inputs are passed as opened Datasets by keyword, ``params.kwargs`` as
extra arguments.
"""

from scintrack import runlog
from scintrack.experiments.guards import divergence_note
from scintrack.io import open_dataset
from scintrack.products import get
from scintrack.products.figures.common import add_footer, save_figure

sm = snakemake  # noqa: F821
product = get(sm.params.product, sm.params.module)
log = runlog.setup(sm.log[0], product.name)
datasets = {name: open_dataset(path, lazy=True) for name, path in sm.input.items()}  # only the variables drawn are read
fig = product.function(*datasets.values(), **dict(sm.params.kwargs))
add_footer(fig, divergence_note(datasets.values()))  # diverged trials / non-estimable S4 of the tracking results read (guards)
written = save_figure(fig, [sm.output.pdf, sm.output.png])
log.info("rendered %s", ", ".join(map(str, written)))
