"""How the trials of a scenario are split: into blocks run one after the other, and batches held in memory.

:func:`trial_blocks` splits a scenario's trials into the experiment's
``shards`` contiguous blocks (each run and merged exactly,
:mod:`scintrack.experiments.shard_job`).

:func:`scintrack.experiments.runner.run_shard` simulates and tracks its trials
in batches (:func:`trial_batches`): whole lane blocks of
:data:`~scintrack.simd.LANES` trials (the compiled trackers run that
many side by side, so a smaller batch would only pad the vectors), holding at
most :data:`BATCH_TRIAL_EPOCHS` trial-epochs, and never less than one lane
block.  A 500-s scenario at 10 ms (50 000 epochs) so runs 32 trials at a time
whatever the block's size, a 60-s one (6 000 epochs) up to 320, a 300-s one at
1 ms (300 000 epochs) one lane block.  No result depends on it: every trial's
signals and estimates are the same in any batch and the statistics over trials
are accumulated in numpy's order (``tests/test_shard_batches.py``); it bounds a
job's memory, and so the fresh pages the kernel has to zero for it.

Light on purpose (no numpy): the workflow's resource model imports it while
Snakemake builds the DAG.
"""

from __future__ import annotations

from .signals.row_blocks import spans
from .simd import LANES

#: trial-epochs a shard simulates and tracks at once
BATCH_TRIAL_EPOCHS = 2_000_000
#: trials whose metrics a shard computes together (row blocks of a batch: the metric temporaries stay small)
METRIC_ROWS = 8


def batch_rows(n_epochs: int, budget: int = BATCH_TRIAL_EPOCHS) -> int:
    """Trials per batch: whole lane blocks holding at most ``budget`` trial-epochs, at least one lane block."""
    return max(budget // max(n_epochs, 1) // LANES, 1) * LANES


def trial_batches(n_trials: int, n_epochs: int, budget: int = BATCH_TRIAL_EPOCHS) -> list[tuple[int, int]]:
    """Blocks ``[lo, hi)`` of ``n_trials`` trials, :func:`batch_rows` trials each (the last one the rest)."""
    return spans(n_trials, batch_rows(n_epochs, budget))


def trials_held(n_trials: int, n_epochs: int, budget: int = BATCH_TRIAL_EPOCHS) -> int:
    """The most trials a shard of ``n_trials`` x ``n_epochs`` holds at once."""
    return min(n_trials, batch_rows(n_epochs, budget))


def trial_blocks(n: int, k: int) -> list[list[int]]:
    """The ``k`` contiguous blocks ("shards") of the trial indices ``0..n-1``.

    The trials are dealt out as evenly as possible, in whole lane blocks of ``LANES`` (32) trials when that
    takes fewer of them: the compiled trackers run a lane block's trials side by side and cost as much for
    a block's last few trials as for 32, so 500 trials in 5 shards run as 96, 96, 128, 96 and 84 trials
    (16 blocks) rather than 5 x 100 (20 blocks).  A trial's results are the same bits in any shard; the
    merge adds the shards' per-epoch sums, so another split groups those additions differently (at the
    rounding level: 1.5e-15 relative in ``sq_sum`` of ``cycle_slips``, no count, table or figure changes).
    """
    edges = [round(i * n / k) for i in range(k + 1)]
    blocks = -(-n // LANES)
    if blocks >= k and blocks < sum(-(-(hi - lo) // LANES) for lo, hi in zip(edges, edges[1:])):
        edges = [min(round(i * blocks / k) * LANES, n) for i in range(k + 1)]
    return [list(range(lo, hi)) for lo, hi in zip(edges, edges[1:])]
