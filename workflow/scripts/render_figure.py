"""Figure rule entry point: call one figure function on its result files.

``params.module``/``params.function`` name the function (the link from a
figure to the code that drew it), inputs are passed as opened Datasets by
keyword, ``params.kwargs`` as extra arguments.
"""

import importlib
from pathlib import Path

from scintrack import runlog
from scintrack.figures.common import save_figure, update_checksums
from scintrack.io import open_dataset

sm = snakemake  # noqa: F821
log = runlog.setup(sm.log[0], sm.params.function)
func = getattr(importlib.import_module(sm.params.module), sm.params.function)
datasets = {name: open_dataset(path) for name, path in sm.input.items()}
fig = func(*datasets.values(), **dict(sm.params.kwargs))
written = save_figure(fig, [sm.output.pdf, sm.output.png])
update_checksums(Path(sm.output.pdf).parent.parent, written)
log.info("rendered %s", ", ".join(map(str, written)))
