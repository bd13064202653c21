"""scintrack: reproducible GNSS carrier tracking under scintillation and jamming.

The library behind the Snakemake pipeline: signal generators (``signals``),
AR scintillation models (``models``), estimators, trackers, experiments,
data registry/IO (``data``, ``io``) and the figure/table renderers.
Everything is importable and testable without Snakemake.
"""

__version__ = "0.1.0"

from . import numba_cache as _numba_cache

_numba_cache.configure()  # before any submodule imports numba: kernels follow every edit of the package
