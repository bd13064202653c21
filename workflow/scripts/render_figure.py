"""Figure rule entry point: call one registered figure function on its result files.

``params.product`` names the rule; :mod:`scintrack.products` holds the
function it was declared on (the link from a figure to the code that drew
it).  Inputs are passed as opened Datasets by keyword, ``params.kwargs`` as
extra arguments.  Beside the PDF and PNG, ``<stem>.json`` records the
figure's gallery entry (paper figure, claim, verdict, data kind) and the
layout check's problems (logged as warnings too).
"""

from scintrack import jobcode
from scintrack.experiments.guards import divergence_note
from scintrack.io import open_dataset
from scintrack.products import get
from scintrack.products.figure_check import check_figure
from scintrack.products.figures.common import STYLE, add_footer, save_figure
from scintrack.products.gallery import figure_record, write_record

sm = snakemake  # noqa: F821
product = get(sm.params.product, sm.params.module)
log = jobcode.begin(sm, product.name)
datasets = {name: open_dataset(path, lazy=True) for name, path in sm.input.items()}  # only the variables drawn are read
kwargs = dict(sm.params.kwargs)
fig = product.function(*datasets.values(), **kwargs)
add_footer(fig, divergence_note(datasets.values()))  # diverged trials / non-estimable S4 of the tracking results read (guards)
problems = check_figure(fig, dpi=STYLE["savefig.dpi"])  # measured as the PNG is drawn
for problem in problems:
    log.warning("layout check: %s", problem)
verdict = product.verdict(*datasets.values(), **kwargs) if product.verdict is not None else None
written = save_figure(fig, [sm.output.pdf, sm.output.png])
write_record(figure_record(product, sm.params.data, verdict, problems, sm.output.png), sm.output.json)
log.info("rendered %s", ", ".join(map(str, written + [sm.output.json])))
