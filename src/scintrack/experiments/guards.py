"""Numerical guards of the trackers: divergence detection per trial, the sanitised estimate, and the note that counts flags.

One concept: a trial whose tracker *diverged*.  :func:`detect` reads a
:class:`~scintrack.trackers.base.TrackOutput` (arrays shaped (trials,
epochs)) and returns, per trial, the first epoch of divergence (int64, -1
none) and a reason code (:data:`REASONS`):

1. **non-finite estimate**: NaN or inf in ``theta_d`` or in any per-epoch
   extra that is not documented as allowed to be non-finite
   (:data:`NONFINITE_ALLOWED`), or a phase estimate (``theta_d``,
   ``total_phase``, ``theta_s``) beyond :data:`PHASE_LIMIT_RAD` (1e12 rad:
   no carrier phase of these runs comes near it, and squares and fourth
   powers of such errors would overflow the mergeable sums to inf);
2. **covariance not positive semi-definite**: the kernel's own test of its
   (phase, frequency) covariance block, ``extras["cov_fail_epoch"]``
   (:func:`scintrack.trackers.blocks.covariance_ok`, recorded inside the
   compiled loop where P lives);
3. **exploding step**: the change of the estimated phase increment from one
   epoch to the next, ``|theta_k - 2 theta_{k-1} + theta_{k-2}|``, above
   :data:`STEP_LIMIT_RAD` = 2 pi.  The second difference is used, not the
   step ``|Delta theta|`` itself: the step carries the Doppler (1200 Hz at
   1 ms is 7.5 rad per epoch, a legitimate value), while its change is what
   the update can move.  A discriminator sees at most pi per epoch (its
   output is in (-pi, pi]) and the phase gain of a KF or loop is below 1, so
   a sane update changes the phase increment by well under pi (the
   10-Hz PLL at 10 ms: at most ``b3 w0 T 2 pi`` = 1.9 rad); a change of 2 pi
   per epoch is a frequency estimate that jumped by 1/T Hz (the whole
   unambiguous range ``+-1/(2T)`` of the correlator) in one epoch, which no
   measurement supports.  Checked on ``theta_d`` and on ``total_phase``.

Ties (two reasons at the same epoch) resolve in the order 2, 1, 3: a
covariance failure is the cause of a non-finite estimate in the same epoch.

:func:`sanitize` makes the metrics of a diverged trial finite and honest:
from its divergence epoch on, every guarded value that is non-finite (or a
phase beyond the limit) is held at the last good value of that trial (a
receiver that lost the signal freezes its NCO), or at ``fallback`` (the
acquisition phase) when the trial never had one.  So a lost lock counts as a
large error and as cycle slips; flagged trials are never dropped from an
average (that would flatter the tracker), they are counted
(:func:`divergence_note`).  A trial that did not diverge is left untouched,
bit for bit.

:func:`divergence_note` turns the per-trial flags stored with the results
(``diverged_epoch``, ``divergence_reason``; :mod:`.runner`) into the line
figures and tables print, and says where on-line S4 estimates were not
estimable (nan-aware means).  The render rules add it to every product
(``workflow/scripts/render_figure.py``: a footer,
:func:`scintrack.products.figures.common.add_footer`; ``render_table.py``: appended
to the table's note, :func:`scintrack.products.tables.common.join_notes`), so no
figure or table function has to remember it; inputs without the guard's
variables (LUTs, diagnostics, the GPS channel results) add nothing.

Where the guard is not applied (yet): trackers run outside
:func:`scintrack.experiments.runner.run_shard`, i.e. the jammed-GPS channel
(:mod:`.gps_receiver` / :mod:`.gps_channel_result`) and the trace
static experiment (:func:`.traces.static_experiment`); their
results carry no flags.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

REASONS = {0: "none", 1: "non-finite estimate", 2: "covariance not positive semi-definite", 3: "exploding step"}
#: CF-style attributes of ``divergence_reason``
REASON_ATTRS = {
    "long_name": "reason of the first divergence of the trial",
    "flag_values": np.array(sorted(REASONS), dtype=np.int8),
    "flag_meanings": " ".join(REASONS[k].replace(" ", "_").replace("-", "_") for k in sorted(REASONS)),
}
PHASE_LIMIT_RAD = 1e12
STEP_LIMIT_RAD = 2 * np.pi
#: extras (trials, epochs) allowed to hold non-finite values by design, and why
NONFINITE_ALLOWED = {
    "s4_hat": "on-line S4 not estimable in this window (NaN)",
    "phi3": "SAKF monitor before its first full window (NaN)",
    "T": "SAKF monitor before its first full window (NaN)",
    "p": "SAKF monitor before its first full window (NaN)",
    "weight": "SAKF monitor before its first full window (NaN)",
    "log_odds": "MM KF soft bit of a known bit (+-inf)",
}
PHASES = ("theta_d", "total_phase", "theta_s")
_TIE_ORDER = (2, 1, 3)


@dataclass(frozen=True)
class Divergence:
    """Per trial: first epoch of divergence (int64, -1 none) and its reason code (int8, :data:`REASONS`)."""

    epoch: np.ndarray
    reason: np.ndarray

    @property
    def flagged(self) -> np.ndarray:
        return self.epoch >= 0

    @property
    def any(self) -> bool:
        return bool(self.flagged.any())


def guarded(out) -> dict[str, np.ndarray]:
    """The arrays the guard checks: ``theta_d`` and every float per-epoch extra not in :data:`NONFINITE_ALLOWED`."""
    theta = np.asarray(out.theta_d)
    arrays = {"theta_d": theta}
    for key, value in out.extras.items():
        if key in NONFINITE_ALLOWED:  # before any conversion: an SAKF monitor is a HeldSeries, expanded by asarray
            continue
        v = np.asarray(value)
        if v.shape == theta.shape and np.issubdtype(v.dtype, np.floating):
            arrays[key] = v
    return arrays


def _bad(key: str, v: np.ndarray) -> np.ndarray:
    # The mask form of the guard's test (sanitize needs it per entry); detect finds the first such entry
    # per trial with the compiled scan reductions.first_nonfinite_kernel, which applies the same test.
    bad = ~np.isfinite(v)
    if key in PHASES:
        bad |= np.abs(np.where(bad, 0.0, v)) > PHASE_LIMIT_RAD
    return bad


def detect(out, ts: float | None = None) -> Divergence:
    """First epoch and reason of divergence per trial of a tracker output (module docstring).

    ``ts`` (the epoch period) is accepted for the interface's sake and not
    used: every bound is per epoch (:data:`STEP_LIMIT_RAD` is a frequency
    jump of 1/T whatever T is).
    """
    theta = np.asarray(out.theta_d)
    if theta.ndim != 2:
        raise ValueError(f"theta_d must be shaped (trials, epochs) (got {theta.shape})")
    n_tr, k = theta.shape
    from .reductions import first_nonfinite_kernel, first_step_kernel  # compiled scans: no full-size masks

    candidates = {}
    first = np.full(n_tr, -1, dtype=np.int64)
    for key, v in guarded(out).items():
        first_nonfinite_kernel(v, key in PHASES, PHASE_LIMIT_RAD, first)
    candidates[1] = first
    cov = out.extras.get("cov_fail_epoch")
    candidates[2] = np.full(n_tr, -1, dtype=np.int64) if cov is None else np.asarray(cov, dtype=np.int64).reshape(n_tr)
    step = np.full(n_tr, -1, dtype=np.int64)
    for key in ("theta_d", "total_phase"):
        v = out.theta_d if key == "theta_d" else out.extras.get(key)
        if v is not None and k >= 3:
            first_step_kernel(np.asarray(v, dtype=float), STEP_LIMIT_RAD, step)  # a NaN compares False: a NaN is reason 1, not 3
    candidates[3] = step
    big = np.iinfo(np.int64).max
    epoch = np.full(n_tr, big, dtype=np.int64)
    reason = np.zeros(n_tr, dtype=np.int8)
    for code in _TIE_ORDER:  # strict <: an earlier code in _TIE_ORDER wins a tie
        e = candidates[code]
        take = (e >= 0) & (e < epoch)
        epoch[take] = e[take]
        reason[take] = code
    epoch[epoch == big] = -1
    return Divergence(epoch=epoch, reason=reason)


def hold_last_good(v: np.ndarray, bad: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """``v`` with every ``bad`` entry replaced by the last good value before it on its row (``fallback`` if none)."""
    k = v.shape[-1]
    idx = np.where(bad, -1, np.arange(k))
    idx = np.maximum.accumulate(idx, axis=-1)
    held = np.take_along_axis(v, np.maximum(idx, 0), axis=-1)
    return np.where(idx < 0, fallback[:, None], np.where(bad, held, v))


def sanitize(out, div: Divergence, fallback: np.ndarray | float = 0.0):
    """A copy of ``out`` whose guarded arrays are held at their last good value from each divergence epoch on.

    Only flagged trials change; ``fallback`` (per trial or scalar) is the value
    of a phase array that has no good value before its first bad one (the
    acquisition phase); other arrays fall back to 0.  Returns ``out`` itself
    when nothing diverged.
    """
    from ..trackers.base import TrackOutput

    if not div.any:
        return out
    rows = np.flatnonzero(div.flagged)
    start = div.epoch[rows]
    fb_phase = np.broadcast_to(np.asarray(fallback, dtype=float), (np.asarray(out.theta_d).shape[0],))[rows]
    fixed = {}
    for key, v in guarded(out).items():
        sub = np.array(v[rows], dtype=float)
        after = np.arange(sub.shape[1])[None, :] >= start[:, None]
        bad = _bad(key, sub) & after
        if bad.any():
            fb = fb_phase if key in PHASES else np.zeros(rows.size)
            v = np.array(v, dtype=float, copy=True)
            v[rows] = hold_last_good(sub, bad, fb)
        fixed[key] = v
    extras = {key: fixed.get(key, value) for key, value in out.extras.items()}
    return TrackOutput(theta_d=fixed["theta_d"], extras=extras)


# --- the note of figures and tables --------------------------------------------------------


def _labels(ds) -> dict[str, str]:
    try:
        return dict(json.loads(ds.attrs.get("tracker_labels", "{}")))
    except (TypeError, ValueError):
        return {}


def divergence_counts(ds) -> list[tuple[str, int, int, float | None]]:
    """Per tracker of one result: (tracker, flagged trials, trials, time of the first divergence [s] or None)."""
    if "diverged_epoch" not in ds:
        return []
    epochs = ds["diverged_epoch"]
    period = float(epochs.attrs.get("epoch_period_s", np.nan))
    rows = []
    for tr in ds["tracker"].values:
        e = np.asarray(epochs.sel(tracker=tr).values)
        hit = e[e >= 0]
        rows.append((str(tr), int(hit.size), int(e.size), float(hit.min() * period) if hit.size else None))
    return rows


def divergence_note(results: Iterable | object) -> str:
    """One line for a figure footer or a table note: which trackers diverged in how many trials, and where
    on-line S4 estimates were not estimable; "" when neither happened.

    ``results``: a result Dataset or several (merged results of :mod:`.runner`;
    other datasets, without ``diverged_epoch``, are ignored).  E.g.
    ``"Diverged (numerical guard): KF 2/500 trials on s4_0.9_tau0_0.1 (first at 12.3 s). Flagged trials stay in every
    average (held estimate = lost lock)."``
    """
    import xarray as xr

    if isinstance(results, xr.Dataset):
        results = [results]
    parts, s4_parts = [], []
    for ds in results:
        if not isinstance(ds, xr.Dataset):
            continue
        labels = _labels(ds)
        scenario = ds.attrs.get("scenario")
        where = f" on {scenario}" if scenario else ""
        for tr, n_hit, n, first in divergence_counts(ds):
            if n_hit:
                parts.append(f"{labels.get(tr, tr)} {n_hit}/{n} trials{where} (first at {first:.3g} s)")
        if "s4_hat_estimable" in ds:
            frac = ds["s4_hat_estimable"]
            for tr in ds["tracker"].values:
                f = np.asarray(frac.sel(tracker=tr).values, dtype=float)
                f = f[np.isfinite(f)]
                if f.size and f.min() < 1.0:
                    s4_parts.append(f"{labels.get(tr, tr)}{where} {100 * (1 - f.mean()):.3g}%")
    note = ""
    if parts:
        note = ("Diverged (numerical guard): " + "; ".join(parts)
                + ". Flagged trials stay in every average (their estimate is held from the divergence on, i.e. counted as lost lock).")
    if s4_parts:
        note += (" " if note else "") + ("On-line S4 not estimable (NaN, left out of the nan-aware S4 means) in this share of the epochs: "
                                        + "; ".join(s4_parts) + ".")
    return note
