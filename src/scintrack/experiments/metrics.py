"""Tracking-error metrics: wrapped/unwrapped error, RMSE with 95% intervals, cycle slips.

* **Error.** ``e_k = theta_hat_d,k - theta_d,k``.  The *unwrapped* error is
  referenced to the integer cycle of the first epoch (the initial phase is
  only known modulo 2 pi); the *wrapped* error is ``angle(exp(j e_k))`` in
  (-pi, pi].  Vila-Valls 2018 does not say which it uses; its RMSE values
  (at most 1.1 rad, with up to 408 cycle slips per run in Table VII) can only
  be wrapped errors: one slip makes an unwrapped RMSE exceed pi/sqrt(3).
* **RMSE over trials** at each epoch, with a 95% interval from the delta
  method on the mean square (normal approximation over trials).
* **Steady-state RMSE**: root of the mean square over trials and over the
  epochs from ``steady_start_s`` to the end; 95% interval from the spread of
  the per-trial mean squares.
* **No interval from one trial.**  Every interval here rests on the spread
  over trials, which one trial does not have: with fewer than two trials
  (finite values, for :func:`mean_ci`) both bounds are NaN, never a
  zero-width interval around the estimate.  Tables print that as words
  (:data:`scintrack.products.tables.common.NO_INTERVAL`).
* **Cycle slips**: the unwrapped error has stable points at ``2 pi n``
  (ATAN2-type tracking).  The error *leaves its cell* when it is more than
  ``pi + hysteresis`` from the cell centre; the cell then becomes the nearest
  multiple of 2 pi.  Noise that stays within the lock region
  (``|e - 2 pi n| < pi + hysteresis``) is never counted.  Two counts:

  - **cycles slipped**: every 2 pi the error moves counts (a slip of k cycles
    counts k; a loop that has lost lock and free-runs counts every cycle);
  - **slip events**: a run of cell changes counts once; the event ends when
    the error has stayed in one cell for ``settle`` epochs.  A loop that loses
    lock for good is one event.
"""

from __future__ import annotations

import warnings

import numpy as np

Z95 = 1.959963984540054


def unwrapped_error(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    e = np.asarray(estimate) - np.asarray(truth)
    return e - 2 * np.pi * np.round(e[..., :1] / (2 * np.pi))


def wrap(e: np.ndarray) -> np.ndarray:
    """``e`` wrapped to (-pi, pi]: ``angle(exp(j e))``, computed by reducing whole cycles (compiled).

    A value in [-pi, pi] is returned as it is (a loop in lock: most samples);
    others lose the nearest whole number of cycles with a two-part 2 pi, to
    the last place of the exact reduction (:func:`~.reductions.wrap_kernel`).
    ``arctan2(sin e, cos e)`` returns an in-range value only to within a
    unit in its last place and costs ~40 ns per sample in libm, about a sixth
    of a tracking job; the two forms differ by rounding only.  NaN and +-inf
    give NaN.
    """
    from .reductions import wrap_kernel

    a = np.asarray(e, dtype=float)
    flat = np.ascontiguousarray(a).reshape(-1)
    out = np.empty_like(flat)
    wrap_kernel(flat, out)
    out = out.reshape(a.shape)
    return out[()] if out.ndim == 0 else out


def derotated_sums(y: np.ndarray, phase: np.ndarray, per: int, start: int = 0, count: int | None = None) -> np.ndarray:
    """Sums of ``y exp(-j phase)`` over ``count`` consecutive blocks of ``per`` epochs from epoch ``start``: (trials, count).

    ``y`` (complex) and ``phase`` (rad) are (trials, epochs); ``count`` defaults to every whole block.  The
    values of ``(y * numpy.exp(-1j * phase))[:, start:start + count per].reshape(trials, count, per).sum(-1)``
    (the lock detector's and the Costas PLL's bit sums), bit for bit for arrays of 256 KiB and more on a
    CPU with FMA, to a few units in the last place otherwise (numpy's complex product and pairwise sum:
    :func:`~.reductions.derotated_sums_kernel`), without that form's (trials, epochs)
    temporaries.
    """
    from .reductions import derotated_sums_kernel

    y = np.asarray(y)
    phase = np.asarray(phase, dtype=float)
    if y.ndim != 2 or phase.shape != y.shape:
        raise ValueError(f"y and phase must be (trials, epochs) arrays of one shape (got {y.shape} and {phase.shape})")
    per, start = int(per), int(start)
    if per < 1 or start < 0:
        raise ValueError(f"per must be >= 1 and start >= 0 (got per={per}, start={start})")
    available = max(y.shape[1] - start, 0) // per
    count = available if count is None else int(count)
    if not 0 <= count <= available:
        raise ValueError(f"count = {count} blocks of {per} epochs from epoch {start} do not fit in {y.shape[1]} epochs")
    out = np.empty((y.shape[0], count), dtype=complex)
    derotated_sums_kernel(y.astype(complex, copy=False), phase, start, per, out)
    return out


def rmse_with_ci(sq_sum: np.ndarray, sq2_sum: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """RMSE and its 95% interval from sums over ``n`` trials of e^2 and e^4 (NaN bounds when ``n < 2``)."""
    ms = sq_sum / n
    if n < 2:  # no spread over trials: no interval
        nan = np.full_like(np.sqrt(ms), np.nan)
        return np.sqrt(ms), nan, nan.copy()
    var_ms = np.maximum(sq2_sum / n - ms**2, 0.0) / (n - 1)
    half = Z95 * np.sqrt(var_ms)
    return np.sqrt(ms), np.sqrt(np.maximum(ms - half, 0.0)), np.sqrt(ms + half)


def mean_ci(x: np.ndarray, axis: int = -1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean and normal-approximation 95% interval of the mean along ``axis``, over the finite values.

    NaN values are left out; where fewer than two values are finite the bounds are NaN.
    """
    m = np.nanmean(x, axis=axis)
    n = np.sum(np.isfinite(x), axis=axis)
    with warnings.catch_warnings():  # numpy warns of the ddof=1 spread of a single value, which is masked below
        warnings.simplefilter("ignore", RuntimeWarning)
        half = 1.96 * np.nanstd(x, axis=axis, ddof=1) / np.sqrt(np.maximum(n, 1))
    half = np.where(n >= 2, half, np.nan)[()]
    return m, m - half, m + half


def steady_rmse(ms_per_trial: np.ndarray, axis: int = -1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Steady-state RMSE and 95% interval from per-trial mean squares (NaN bounds from one trial)."""
    ms = np.asarray(ms_per_trial)
    n = ms.shape[axis]
    mean = ms.mean(axis=axis)
    half = Z95 * ms.std(axis=axis, ddof=1) / np.sqrt(n) if n > 1 else np.full_like(mean, np.nan, dtype=float)
    return np.sqrt(mean), np.sqrt(np.maximum(mean - half, 0.0)), np.sqrt(mean + half)


def count_cycle_slips(e_unwrapped: np.ndarray, hysteresis: float = 0.5) -> np.ndarray:
    """Cycles slipped per trial of an unwrapped error shaped (trials, epochs)."""
    return slip_counts(e_unwrapped, hysteresis, settle=1)[0]


def slip_counts(e_unwrapped: np.ndarray, hysteresis: float, settle: int) -> tuple[np.ndarray, np.ndarray]:
    """(cycles slipped, slip events) per trial (compiled kernel)."""
    from .reductions import cycle_slip_kernel

    return cycle_slip_kernel(np.ascontiguousarray(np.atleast_2d(e_unwrapped), dtype=float), float(hysteresis), int(max(settle, 1)))


def count_cycle_slips_numpy(e_unwrapped: np.ndarray, hysteresis: float = 0.5) -> np.ndarray:
    """Vectorised numpy reference of :func:`count_cycle_slips`."""
    e = np.atleast_2d(e_unwrapped)
    two_pi = 2 * np.pi
    level = np.round(e[:, 0] / two_pi)
    slips = np.zeros(e.shape[0], dtype=np.int64)
    limit = np.pi + hysteresis
    for k in range(1, e.shape[1]):
        ek = e[:, k]
        out = np.abs(ek - two_pi * level) >= limit
        if out.any():
            new = np.round(ek[out] / two_pi)
            slips[out] += np.abs(new - level[out]).astype(np.int64)
            level[out] = new
    return slips


def mean_with_ci(values: np.ndarray, axis: int = -1, lower: float | None = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean and normal 95% interval, clipped at ``lower`` (counts cannot be negative); NaN bounds from one value."""
    v = np.asarray(values, dtype=float)
    n = v.shape[axis]
    m = v.mean(axis=axis)
    half = Z95 * v.std(axis=axis, ddof=1) / np.sqrt(n) if n > 1 else np.full_like(m, np.nan)
    lo = m - half if lower is None else np.maximum(m - half, lower)
    return m, lo, m + half
