"""One scalar formula evaluated for many trials at once.

:mod:`.lanes`: the ``Lanes`` type, ``LANES`` trials as one SIMD vector inside
compiled kernels; :mod:`.ufunc`: the numpy ufunc of a scalar formula, for
array code.  Both compile the same Python function as the scalar call, so a
formula is written once and every form gives the same bits.

``LANES`` is defined here, apart from numba, so that light code sizes its
batches by it without importing numba: the tracking shards simulate and track
whole lane blocks of trials (:mod:`scintrack.batching`) and the
workflow's resource model (:mod:`scintrack.pipeline.resources`) predicts a
shard's memory from the same blocks.  Why 32: :mod:`.lanes`.
"""

LANES = 32
