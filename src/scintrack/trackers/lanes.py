"""How many trials the compiled trackers run side by side (one SIMD vector per matrix entry).

Defined here, apart from the numba blocks that use it (:mod:`.blocks`, the
``Lanes`` type), so that light code can size its batches by it without
importing numba: the tracking shards simulate and track whole lane blocks of
trials at a time (:mod:`scintrack.experiments.batching`), and the resource
model of the workflow (:mod:`scintrack.pipeline.resources`) predicts a
shard's memory from the same blocks.  Why 32: :mod:`.blocks`, "lanes".
"""

LANES = 32
