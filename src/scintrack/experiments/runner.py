"""Monte Carlo runner: one shard (scenario x trackers x a block of trials).

A shard's result holds only *mergeable* statistics, so shards can run as
separate jobs (or on a cluster) and be combined exactly by :func:`~scintrack.experiments.merge.merge`:

* ``sq_sum`` / ``sq2_sum`` (tracker, kind, time): sums over trials of e^2 and
  e^4, ``kind`` in {wrapped, unwrapped} (see :mod:`.metrics`);
* ``ms_steady`` (tracker, kind, trial): per-trial mean square over the
  steady-state window;
* ``slips`` / ``slip_events`` (tracker, trial): cycles slipped and slip
  events per trial (see :mod:`.metrics`);
* ``example_error`` (tracker, time): the unwrapped error of the shard's first
  trial (Fig. 16 shows one realisation);
* ``s4_true`` (time) and, for adaptive trackers, ``s4_hat_mean`` (tracker, time)
  and ``s4_hat_median`` (tracker, trial), each trial's median over the
  steady-state window (robust to the epochs where the M2M4-corrected estimate
  explodes); a non-finite estimate means "not estimable in this window": both
  statistics skip it (:func:`s4_statistics`) and ``s4_hat_estimable``
  (tracker, time) is the fraction of trial-epochs that were estimable (NaN for
  trackers without an S4 estimate);
* ``design_s4`` / ``design_tau0`` (tracker): the AR look-up-table point a
  fixed-design tracker was built with (the grid point actually used, within
  :func:`scintrack.models.lut.within_tolerance` of the request; NaN for
  adaptive trackers and trackers without a scintillation model);
* ``diverged_epoch`` / ``divergence_reason`` (tracker, trial): the numerical
  guard (:mod:`.guards`): first epoch of divergence (-1 none; attribute
  ``epoch_period_s``) and its reason code (``flag_values`` /
  ``flag_meanings``).  A diverged trial's estimate is held at its last good
  value from that epoch on (:func:`.guards.sanitize`), so every metric below
  counts it as lost lock and stays finite; it is never left out.  A run in
  which nothing diverges gives every other variable exactly as without the
  guard;
* for trackers that report their discriminator output (the PLL and the Susi
  KF PLLs, Susi et al. 2014): ``jitter_discriminator`` (tracker, trial,
  window), the standard deviation of the discriminator output over
  consecutive ``tracking.jitter_window_s`` windows (the chapter's "phase
  jitter"), and ``jitter_tracking`` the same for the true total-phase
  tracking error ``wrap(theta_hat - theta_d - theta_s)``; examples of the
  first trial: ``example_discriminator``, ``example_frequency`` (the carrier
  Doppler estimate, with ``example_frequency_true``); means over trials of the
  SAKF's on-line ``phi3``/``p``/``weight`` and median of ``T``.

Total-phase metrics (every tracker): the error of the tracker's estimate of
the *total* carrier phase against ``theta_d + theta_s``, i.e. what a
receiver's carrier phase measurement delivers (Susi et al.'s view; the
Vila-Valls metric above is the theta_d error alone, which charges a loop
without a scintillation model for following the scintillation).  The total
estimate is ``extras["total_phase"]`` where a tracker has AR states (AKF-AR:
``H x``), ``theta_d + theta_s`` estimates for the AEKF-AR, and ``theta_d``
itself for every other tracker (they track the total phase).
``ms_total_steady`` (tracker, trial) over the steady-state window (wrapped
error) and ``slip_events_total`` / ``slips_total`` (tracker, trial).

Lock (every tracker): the standard narrow-band phase lock detector on the
prompts de-rotated by the tracker's total-phase estimate, over consecutive
blocks of ``tracking.lock_window_s``: ``C2phi = ((sum I)^2 -
(sum Q)^2) / ((sum I)^2 + (sum Q)^2)`` (``cos 2 dphi`` without noise), and,
since every signal here is a pilot, ``sum I > 0``; a block is in lock when
both hold with ``C2phi >= tracking.lock_threshold`` (0.85: |dphi| < 16 deg).
``time_in_lock`` (tracker, trial) is the fraction of blocks in lock in the
steady-state window, so an RMSE near pi/sqrt(3) can be read as what it is (a
tracker out of lock).

Per-epoch statistics (everything on the ``time`` dimension) are block means
over ``tracking.stats_resolution_s`` (10 ms: at the 10-ms scenarios one epoch,
so nothing changes there; 10 epochs at 1 ms, which keeps a 1-ms result small).
Per-trial statistics (steady-state mean square, slips, jitter) use every epoch.

Trackers are built through :mod:`scintrack.trackers.registry`; their labels go
into the dataset attribute ``tracker_labels`` (canonical JSON ``{name: label}``;
an attribute, so the content hash of the results does not depend on them).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
import xarray as xr

from ..batching import BATCH_TRIAL_EPOCHS, METRIC_ROWS, trial_batches
from ..io import canonical_json
from ..progress import Progress
from ..signals.row_blocks import spans
from ..trackers import registry
from ..trackers.base import TrackerContext
from ..trackers.held_series import HeldSeries
from . import guards
from .merge import MONITORS, merge  # noqa: F401  (merge: re-exported; it lives in .merge, light to import)
from .metrics import derotated_sums, slip_counts, unwrapped_error, wrap
from .scenario import acquisition, effective_tracking, scenario_epochs, simulate

KINDS = ("wrapped", "unwrapped")
#: the optional tracker outputs the metrics read (:meth:`scintrack.trackers.base.Tracker.request`)
WANTED = ("total_phase", "theta_s", "s4_hat", "discriminator", "frequency_hz", *MONITORS)


def block_mean(a: np.ndarray, block: int) -> np.ndarray:
    """Means over consecutive blocks of ``block`` samples along the last axis (``block = 1``: ``a`` itself)."""
    a = np.asarray(a)
    if block == 1:
        return a
    nb = a.shape[-1] // block
    return a[..., : nb * block].reshape(*a.shape[:-1], nb, block).mean(axis=-1)


def time_in_lock(y: np.ndarray, total_hat: np.ndarray, per: int, threshold: float, start: int) -> np.ndarray:
    """Fraction of lock-detector blocks in lock from epoch ``start`` on, per trial (see the module docstring)."""
    s = derotated_sums(y, total_hat, per, start)
    if s.shape[1] == 0:
        return np.full(y.shape[0], np.nan)
    i2, q2 = s.real**2, s.imag**2
    locked = (s.real > 0) & ((i2 - q2) >= threshold * (i2 + q2))
    return locked.mean(axis=1)


def s4_statistics(s4: np.ndarray, block: int, steady: slice) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mean over trials per time block, per-trial median over ``steady``, estimable fraction per time block) of an
    on-line S4 estimate (trials, epochs) in which a non-finite value means "not estimable in this window".

    Without such values the mean and the median are the plain ``mean`` / ``median`` (the bits of the runner
    before the guard).  With them, the mean is over the estimable trial-epochs of each block (NaN where there
    is none) and the median over each trial's estimable epochs (NaN for a trial without any), computed without
    all-NaN warnings; the fraction (``s4_hat_estimable``) says how much of the data they rest on, so a
    figure can say it (:func:`.guards.divergence_note`).  The batch-by-batch form is :class:`S4Statistics`.
    """
    acc = S4Statistics()
    med = acc.add(s4, steady)
    mean, frac = acc.result(block)
    return mean, med, frac


class RowSum:
    """Sum over rows (trials) accumulated batch by batch, bit for bit ``rows.sum(axis=0)`` of all rows.

    numpy reduces axis 0 of a C-ordered array by copying the first row and adding
    the others one at a time, in order; so does this, across batches.
    """

    def __init__(self) -> None:
        self.total: np.ndarray | None = None

    def add(self, rows: np.ndarray) -> None:
        rows = np.asarray(rows)
        first = 0
        if self.total is None:
            self.total = rows[0].copy()
            first = 1
        for r in rows[first:]:
            self.total += r


class S4Statistics:
    """:func:`s4_statistics` accumulated over batches of trials: the same bits as on all trials at once."""

    def __init__(self) -> None:
        self.sum, self.count = RowSum(), RowSum()
        self.n = 0
        self.all_ok = True

    def add(self, s4: np.ndarray, steady: slice) -> np.ndarray:
        """Add a batch (trials, epochs); returns its per-trial medians over ``steady``."""
        ok = np.isfinite(s4)
        self.n += s4.shape[0]
        self.count.add(ok.astype(np.intp))
        if ok.all():
            self.sum.add(s4)
            return np.median(s4[:, steady], axis=1)  # equals nanmedian on rows without NaN (bit for bit)
        self.all_ok = False
        self.sum.add(np.where(ok, s4, 0.0))
        sub = np.where(ok[:, steady], s4[:, steady], np.nan)
        med = np.full(s4.shape[0], np.nan)
        has = ok[:, steady].any(axis=1)
        if has.any():
            med[has] = np.nanmedian(sub[has], axis=1)
        return med

    def result(self, block: int) -> tuple[np.ndarray, np.ndarray]:
        """(mean over trials per time block, estimable fraction per time block)."""
        frac = block_mean(self.count.total / self.n, block)
        if self.all_ok:
            return block_mean(self.sum.total / self.n, block), frac
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = block_mean(self.sum.total, block) / block_mean(self.count.total.astype(float), block)
        return mean, frac


class ColumnLayout:
    """The columns a reduction over trials is fed: plain (trials, epochs) arrays, or one
    :class:`~scintrack.trackers.held_series.HeldSeries` layout (the SAKF's monitors).

    A reduction over trials works column by column, so on a held series it gives the same bits on the
    values of each run as on every epoch of the run (each epoch's column is its run's column); it is
    computed on the runs and only its 1-D result is expanded (:meth:`expand`).  Every batch of one
    reduction must come in the same layout.
    """

    def __init__(self) -> None:
        self.held: HeldSeries | None = None
        self.seen = False

    def columns(self, rows):
        """The array to reduce over its rows: ``rows`` itself, or a held series' per-run values."""
        held = rows if isinstance(rows, HeldSeries) else None
        if not self.seen:
            self.seen, self.held = True, held
        elif (held is None) != (self.held is None) or (held is not None and not held.same_runs(self.held)):
            raise ValueError("the batches of one reduction over trials must share their column layout")
        return np.asarray(rows) if held is None else held.values

    def expand(self, result: np.ndarray) -> np.ndarray:
        """The reduction's result per epoch."""
        return result if self.held is None else self.held.expand_columns(result)


class TrialMedian:
    """``np.nanmedian(values, axis=0)`` over all ``n`` trials, fed batch by batch.

    The median is taken once the last trial is in, and the trials' values are
    dropped then; a single batch holding every trial is used as it is (no copy).
    All-NaN epochs (the SAKF's monitors before their first window) give NaN
    without a warning.  The median is the compiled
    :func:`~.reductions.column_nanmedian_kernel`: numpy's own
    over fewer than 600 trials sorts masked copies of the whole array (~0.5 s
    and ~0.3 GB of fresh memory per SAKF in a 25 x 300 000 shard).  A held
    series (:class:`ColumnLayout`) is reduced on its runs.
    """

    def __init__(self, n: int) -> None:
        self.n, self.filled = n, 0
        self.values: np.ndarray | None = None
        self.median: np.ndarray | None = None
        self.layout = ColumnLayout()

    def add(self, rows: np.ndarray) -> None:
        rows = self.layout.columns(rows)
        if self.filled == 0 and rows.shape[0] == self.n:
            values = rows
        else:
            if self.values is None:
                self.values = np.empty((self.n, rows.shape[1]))
            self.values[self.filled : self.filled + rows.shape[0]] = rows
            values = self.values
        self.filled += rows.shape[0]
        if self.filled == self.n:
            from .reductions import column_nanmedian_kernel  # np.nanmedian(values, axis=0), bit for bit, no masked copies

            self.median = np.empty(values.shape[1])
            column_nanmedian_kernel(np.asarray(values, dtype=float), self.median)
            self.values = None

    def result(self) -> np.ndarray:
        return self.layout.expand(self.median)


class NanMean:
    """``np.nanmean(rows, axis=0)`` over all batches of rows, bit for bit (NaN, without a warning, where no row
    has a value); a held series (:class:`ColumnLayout`) is reduced on its runs."""

    def __init__(self) -> None:
        self.sum, self.count = RowSum(), RowSum()
        self.layout = ColumnLayout()

    def add(self, rows: np.ndarray) -> None:
        rows = self.layout.columns(rows)
        nan = np.isnan(rows)
        self.sum.add(np.where(nan, 0.0, rows))
        self.count.add((~nan).astype(np.intp))

    def result(self) -> np.ndarray:
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.layout.expand(np.divide(self.sum.total, self.count.total))


def window_std(a: np.ndarray, per: int) -> np.ndarray:
    """Standard deviation over consecutive windows of ``per`` samples along the last axis."""
    nw = a.shape[-1] // per
    return a[..., : nw * per].reshape(*a.shape[:-1], nw, per).std(axis=-1)


def run_shard(
    *,
    scenario_name: str,
    scenario: Mapping[str, Any],
    tracker_names: Sequence[str],
    tracker_specs: Mapping[str, Mapping[str, Any]],
    tracking: Mapping[str, Any],
    lut: xr.Dataset,
    seed: int,
    ts: float,
    nspa: int,
    warmup_s: float,
    trials: Sequence[int],
    trace: tuple[np.ndarray, np.ndarray] | None = None,
    trace_set=None,
    progress: Callable[[str], object] | None = None,
    batch_trial_epochs: int = BATCH_TRIAL_EPOCHS,
) -> xr.Dataset:
    """One shard; ``trace``/``trace_set``: a recorded scintillation and its fitted AR models (Sec. VI-E).

    ``progress``: where to write progress lines (filter-epochs done, rate, ETA;
    :class:`scintrack.progress.Progress`), e.g. the job log's ``info``.

    The trials are simulated and tracked in batches of at most
    ``batch_trial_epochs`` trial-epochs (:func:`trial_batches`), every tracker on
    one batch before the next batch is simulated.  Every trial's signals and
    estimates are the same in any batch (one seed stream per trial, trackers
    that treat trials independently), per-trial statistics are computed row by
    row and sums over trials are accumulated in numpy's order
    (:class:`RowSum`), so the result is the same bits for any batching
    (``tests/test_shard_batches.py``).
    """
    tracking = effective_tracking(scenario, tracking)
    trials = np.asarray(list(trials))
    n_tr = trials.size
    n_epochs = scenario_epochs(scenario, ts)
    block = max(int(round(tracking.stats_resolution_s / ts)), 1)
    n_stat = n_epochs // block
    per_window = max(int(round(tracking.jitter_window_s / ts)), 1)
    n_windows = n_epochs // per_window
    steady = slice(int(round(tracking.steady_state_start_s / ts)), None)
    if steady.start >= n_epochs:
        raise ValueError(f"scenario {scenario_name!r}: steady_state_start_s is beyond its duration")
    hyst = tracking.slip_hysteresis_rad
    settle = int(round(tracking.slip_settle_s / ts))
    nt = len(tracker_names)
    sq = [[RowSum() for _ in KINDS] for _ in range(nt)]
    sq2 = [[RowSum() for _ in KINDS] for _ in range(nt)]
    ms = np.zeros((nt, 2, n_tr))
    slips = np.zeros((nt, n_tr), dtype=np.int64)
    events = np.zeros_like(slips)
    example = np.zeros((nt, n_stat))
    s4_acc: dict[int, S4Statistics] = {}
    s4_med = np.full((nt, n_tr), np.nan)
    div_epoch = np.full((nt, n_tr), -1, dtype=np.int64)
    div_reason = np.zeros((nt, n_tr), dtype=np.int8)
    design = np.full((nt, 2), np.nan)  # the AR-grid point a fixed-design tracker was built with (NaN: adaptive / none)
    jit_disc = np.full((nt, n_tr, n_windows), np.nan)
    jit_track = np.full_like(jit_disc, np.nan)
    ex_disc = np.full((nt, n_stat), np.nan)
    ex_freq = np.full((nt, n_stat), np.nan)
    monitor_acc: dict[tuple[int, str], NanMean | TrialMedian] = {}  # (tracker, monitor): T is a median over trials, the others means
    ms_tot = np.zeros((nt, n_tr))
    lock = np.zeros((nt, n_tr))
    lock_per = max(int(round(tracking.lock_window_s / ts)), 1)
    lock_threshold = tracking.lock_threshold
    slips_tot = np.zeros((nt, n_tr), dtype=np.int64)
    events_tot = np.zeros_like(slips_tot)
    context = TrackerContext(scenario=scenario, tracking=tracking.given(), lut=lut, ts=ts, trace_set=trace_set)
    prog = Progress(nt * n_tr * n_epochs, unit="filter-epochs", log=progress, label=f"{scenario_name} ({n_tr} trials)")
    first = None  # the first batch's truths: the example trial and the scenario's profile
    # Each tracker is built once and runs every batch (a tracker holds its settings, no run state): a build
    # may look AR models up in the table, ten pairs for an adaptive AEKF-AR.
    trackers = [registry.build(name, tracker_specs[name], context) for name in tracker_names]
    given = [tracker.request(WANTED) for tracker in trackers]  # the optional outputs each tracker's run gives
    for j, tracker in enumerate(trackers):
        if tracker.design_point is not None:
            design[j] = tracker.design_point
    for lo, hi in trial_batches(n_tr, n_epochs, batch_trial_epochs):
        real = simulate(scenario_name, scenario, tracking, seed=seed, ts=ts, nspa=nspa, warmup_s=warmup_s, trials=trials[lo:hi], lut=lut, trace=trace)
        init = acquisition(real, tracking)
        # The scintillation's phase and amplitude are not needed once the prompts and the total phase exist:
        # theta_s's array becomes the total phase (the same sum, in place) and rho_s is released, so a
        # batch holds two (trials, epochs) arrays fewer (120 MB in a Susi shard).
        total_phase = np.add(real.theta_d, real.theta_s, out=real.theta_s)
        real.theta_s = real.rho_s = None
        if first is None:
            first = {"s4_t": real.s4_t, "tau0_t": real.tau0_t, "time": real.time, "total_phase": total_phase[0].copy()}
        rows = slice(lo, hi)
        for j, (name, tracker) in enumerate(zip(tracker_names, trackers)):
            tracker_init = replace(init, noise_reference=real.noise_reference()) if tracker.needs_noise_reference else init
            out = tracker.run(real.y, tracker_init)
            if set(out.extras) != given[j]:
                raise RuntimeError(f"tracker {name!r} gave the outputs {sorted(out.extras)}, its request() declared {sorted(given[j])}")
            div = guards.detect(out, ts)
            div_epoch[j, rows], div_reason[j, rows] = div.epoch, div.reason
            out = guards.sanitize(out, div, fallback=init.phase)
            for r0, r1 in spans(hi - lo, METRIC_ROWS):  # the metrics a few trials at a time: small temporaries
                c, g = slice(r0, r1), slice(lo + r0, lo + r1)  # rows of the batch, of the shard
                if "total_phase" in given[j]:
                    total_hat = out.extras["total_phase"][c]
                elif "theta_s" in given[j]:
                    total_hat = out.theta_d[c] + out.extras["theta_s"][c]
                else:
                    total_hat = out.theta_d[c]
                lock[j, g] = time_in_lock(real.y[c], total_hat, lock_per, lock_threshold, steady.start)
                et = unwrapped_error(total_hat, total_phase[c])
                ms_tot[j, g] = (wrap(et[:, steady]) ** 2).mean(axis=1)
                slips_tot[j, g], events_tot[j, g] = slip_counts(et, hyst, settle)
                del et, total_hat
                eu = unwrapped_error(out.theta_d[c], real.theta_d[c])
                for kk, e in enumerate((wrap(eu), eu)):
                    e2 = e**2
                    ms[j, kk, g] = e2[:, steady].mean(axis=1)
                    e2 = block_mean(e2, block)
                    sq[j][kk].add(e2)
                    sq2[j][kk].add(e2**2)
                slips[j, g], events[j, g] = slip_counts(eu, hyst, settle)
                if g.start == 0:
                    example[j] = block_mean(eu[0], block)
                if "s4_hat" in given[j]:
                    s4_med[j, g] = s4_acc.setdefault(j, S4Statistics()).add(out.extras["s4_hat"][c], steady)
                if "discriminator" in given[j]:
                    disc = out.extras["discriminator"][c]
                    jit_disc[j, g] = window_std(disc, per_window)
                    jit_track[j, g] = window_std(wrap(out.theta_d[c] - total_phase[c]), per_window)
                    if g.start == 0:
                        ex_disc[j] = block_mean(disc[0], block)
                if "frequency_hz" in given[j] and g.start == 0:
                    ex_freq[j] = block_mean(out.extras["frequency_hz"][0], block)
                for m in MONITORS:
                    if m in given[j] and m != "T":
                        monitor_acc.setdefault((j, m), NanMean()).add(out.extras[m][c])
                eu = e = e2 = disc = None
            if "T" in given[j]:  # a median over trials: fed a whole batch at a time
                monitor_acc.setdefault((j, "T"), TrialMedian(n_tr)).add(out.extras["T"])
            out = None  # the next tracker runs without this one's arrays
            prog.add((hi - lo) * n_epochs, note=f"{name} done (trials {trials[lo]}..{trials[hi - 1]})")
        real = init = total_phase = None
    s4_hat = np.full((nt, n_stat), np.nan)
    s4_ok = np.full((nt, n_stat), np.nan)
    for j, acc in s4_acc.items():
        s4_hat[j], s4_ok[j] = acc.result(block)
    monitors = {m: np.full((nt, n_stat), np.nan) for m in MONITORS}
    for (j, m), acc in monitor_acc.items():
        monitors[m][j] = block_mean(acc.result(), block)
    sq = np.array([[acc.total for acc in row] for row in sq])
    sq2 = np.array([[acc.total for acc in row] for row in sq2])
    ds = xr.Dataset(
        {
            "sq_sum": (("tracker", "kind", "time"), sq, {"long_name": "sum over trials of the squared phase error", "units": "rad2"}),
            "sq2_sum": (("tracker", "kind", "time"), sq2, {"long_name": "sum over trials of the 4th power of the phase error", "units": "rad4"}),
            "ms_steady": (("tracker", "kind", "trial"), ms, {"long_name": "per-trial mean square error over the steady-state window", "units": "rad2"}),
            "slips": (("tracker", "trial"), slips, {"long_name": "cycles slipped per trial", "units": "1"}),
            "slip_events": (("tracker", "trial"), events, {"long_name": "slip events per trial", "units": "1"}),
            "example_error": (("tracker", "time"), example, {"long_name": "unwrapped phase error of the first trial of the shard", "units": "rad"}),
            "example_trial": ((), int(trials[0])),
            "ms_total_steady": (("tracker", "trial"), ms_tot, {"long_name": "per-trial mean square of the wrapped total-phase error over the steady-state window", "units": "rad2"}),
            "slips_total": (("tracker", "trial"), slips_tot, {"long_name": "cycles slipped by the total-phase error per trial", "units": "1"}),
            "slip_events_total": (("tracker", "trial"), events_tot, {"long_name": "slip events of the total-phase error per trial", "units": "1"}),
            "time_in_lock": (("tracker", "trial"), lock, {"long_name": "fraction of lock-detector blocks in lock over the steady-state window", "units": "1"}),
            "s4_true": (("time",), block_mean(first["s4_t"], block), {"long_name": "S4 of the CSM profile", "units": "1"}),
            "tau0_true": (("time",), block_mean(first["tau0_t"], block), {"long_name": "tau0 of the CSM profile", "units": "s"}),
            "s4_hat_mean": (("tracker", "time"), s4_hat, {"long_name": "mean over trials of the on-line S4 estimate (adaptive trackers)", "units": "1"}),
            "s4_hat_median": (("tracker", "trial"), s4_med, {"long_name": "per-trial median of the on-line S4 estimate over the steady-state window", "units": "1"}),
            "s4_hat_estimable": (("tracker", "time"), s4_ok, {"long_name": "fraction of the trial-epochs of each time block with an estimable on-line S4", "units": "1"}),
            "diverged_epoch": (("tracker", "trial"), div_epoch, {"long_name": "first epoch of divergence of the trial (-1: none)", "units": "1",
                                                                  "epoch_period_s": float(ts)}),
            "divergence_reason": (("tracker", "trial"), div_reason, dict(guards.REASON_ATTRS)),
            "design_s4": (("tracker",), design[:, 0], {"long_name": "S4 of the AR-grid point the tracker was designed for (NaN: adaptive or none)", "units": "1"}),
            "design_tau0": (("tracker",), design[:, 1], {"long_name": "tau0 of the AR-grid point the tracker was designed for (NaN: adaptive or none)", "units": "s"}),
            "n_trials": ((), int(n_tr)),
        },
        coords={
            "tracker": list(tracker_names),
            "kind": list(KINDS),
            "trial": trials,
            "time": ("time", block_mean(first["time"], block), {"units": "s", "long_name": "time"}),
        },
    )
    if any(np.isfinite(jit_disc).any(axis=(1, 2))) or any(np.isfinite(ex_freq).any(axis=1)):
        tp0 = first["total_phase"]
        truth_freq = np.diff(tp0, append=2 * tp0[-1] - tp0[-2]) / (2 * np.pi * ts)
        ds["jitter_discriminator"] = (("tracker", "trial", "window"), jit_disc,
                                      {"long_name": "std of the discriminator output over each window (Susi's phase jitter)", "units": "rad"})
        ds["jitter_tracking"] = (("tracker", "trial", "window"), jit_track,
                                 {"long_name": "std of the wrapped total-phase tracking error over each window", "units": "rad"})
        ds["example_discriminator"] = (("tracker", "time"), ex_disc, {"long_name": "discriminator output, first trial of the shard", "units": "rad"})
        ds["example_frequency"] = (("tracker", "time"), ex_freq, {"long_name": "carrier Doppler estimate, first trial of the shard", "units": "Hz"})
        ds["example_frequency_true"] = (("time",), block_mean(truth_freq, block), {"long_name": "true carrier Doppler (dynamics + clock + scintillation), first trial", "units": "Hz"})
        for m, v in monitors.items():
            ds[f"{m}_mean"] = (("tracker", "time"), v, {"long_name": f"{'median' if m == 'T' else 'mean'} over trials of the on-line {m} (SAKF)"})
        ds = ds.assign_coords(window=("window", (np.arange(n_windows) + 0.5) * per_window * ts, {"units": "s", "long_name": "window centre"}))
    ds.attrs.update(
        {
            "scenario": scenario_name,
            "steady_state_start_s": tracking.steady_state_start_s,
            "slip_hysteresis_rad": hyst,
            "slip_settle_s": tracking.slip_settle_s,
            "stats_block_epochs": block,
            "jitter_window_s": per_window * ts,
            "lock_window_s": lock_per * ts,
            "lock_threshold": lock_threshold,
            "tracker_labels": tracker_labels(tracker_names, tracker_specs),
        }
    )
    return ds


def tracker_labels(names: Sequence[str], specs: Mapping[str, Mapping[str, Any]]) -> str:
    """Canonical JSON ``{name: plain-text label}`` (the ``tracker_labels`` attribute of results)."""
    return canonical_json({name: registry.label(name, specs[name]) for name in names})
