"""scintrack: reproducible GNSS carrier tracking under scintillation and jamming.

The library behind the Snakemake pipeline: signal generators (``signals``),
AR scintillation models (``models``), estimators, trackers, experiments,
data registry/IO (``data``, ``io``) and the figure/table renderers.
Everything is importable and testable without Snakemake.
"""

__version__ = "0.1.0"
