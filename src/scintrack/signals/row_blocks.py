"""Row blocks: elementwise work over (trials, samples) arrays done a few rows at a time.

Why: on the virtual machines this pipeline runs on, the first touch of fresh
memory is what a job pays for most (page faults, huge pages zeroed by the
guest and backed again by the host: 1-10 s per GB, ``docs/performance.md``).  An expression such as
``A rho exp(j theta) + n`` over a whole (trials, epochs) array makes several
temporaries of the array's size; done over blocks of rows whose arrays fit
:data:`CHUNK_BYTES`, its temporaries stay small and are reused block after
block.  Every operation so blocked is row-wise (elementwise, or along the
last axis), so the values are the same bits whatever the blocking.
"""

from __future__ import annotations

#: bytes of one block's widest array (8 MB: one to a few rows of a long scenario)
CHUNK_BYTES = 8 * 2**20


def spans(n: int, size: int) -> list[tuple[int, int]]:
    """``[lo, hi)`` spans of ``size`` (the last one the rest) covering ``range(n)``: every blocking of rows uses it."""
    return [(lo, min(lo + size, n)) for lo in range(0, n, size)]


def row_blocks(n_rows: int, row_bytes: int, budget_bytes: int | None = None) -> list[tuple[int, int]]:
    """Blocks ``[lo, hi)`` of rows whose arrays of ``row_bytes`` per row fit the budget (at least one row each).

    ``budget_bytes`` defaults to :data:`CHUNK_BYTES`, read at call time.
    """
    budget = CHUNK_BYTES if budget_bytes is None else budget_bytes
    return spans(n_rows, max(1, int(budget // max(int(row_bytes), 1))))
