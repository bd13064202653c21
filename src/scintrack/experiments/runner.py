"""Monte Carlo runner: one shard (scenario x trackers x a block of trials).

A shard's result holds only *mergeable* statistics, so shards can run as
separate jobs (or on a cluster) and be combined exactly by :func:`merge`:

* ``sq_sum`` / ``sq2_sum`` (tracker, kind, time): sums over trials of e^2 and
  e^4, ``kind`` in {wrapped, unwrapped} (see :mod:`.metrics`);
* ``ms_steady`` (tracker, kind, trial): per-trial mean square over the
  steady-state window;
* ``slips`` / ``slip_events`` (tracker, trial): cycles slipped and slip
  events per trial (see :mod:`.metrics`);
* ``example_error`` (tracker, time): the unwrapped error of the shard's first
  trial (Fig. 16 shows one realisation);
* ``s4_true`` (time) and, for adaptive trackers, ``s4_hat_mean`` (tracker, time).

Trackers are built through :mod:`scintrack.trackers.registry`; their labels go
into the dataset attribute ``tracker_labels`` (canonical JSON ``{name: label}``;
an attribute, so the content hash of the results does not depend on them).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from ..io import canonical_json
from ..trackers import registry
from ..trackers.base import TrackerContext
from .metrics import rmse_with_ci, slip_counts, steady_rmse, unwrapped_error, wrap
from .scenario import acquisition, simulate

KINDS = ("wrapped", "unwrapped")


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
) -> xr.Dataset:
    """One shard; ``trace``/``trace_set``: a recorded scintillation and its fitted AR models (Sec. VI-E)."""
    real = simulate(scenario_name, scenario, tracking, seed=seed, ts=ts, nspa=nspa, warmup_s=warmup_s, trials=trials, lut=lut, trace=trace)
    init = acquisition(real, tracking)
    n_epochs = real.y.shape[1]
    steady = slice(int(round(float(tracking["steady_state_start_s"]) / ts)), None)
    if steady.start >= n_epochs:
        raise ValueError(f"scenario {scenario_name!r}: steady_state_start_s is beyond its duration")
    hyst = float(tracking["slip_hysteresis_rad"])
    settle = int(round(float(tracking["slip_settle_s"]) / ts))
    nt = len(tracker_names)
    sq = np.zeros((nt, 2, n_epochs))
    sq2 = np.zeros_like(sq)
    ms = np.zeros((nt, 2, real.trials.size))
    slips = np.zeros((nt, real.trials.size), dtype=np.int64)
    events = np.zeros_like(slips)
    example = np.zeros((nt, n_epochs))
    s4_hat = np.full((nt, n_epochs), np.nan)
    context = TrackerContext(scenario=scenario, tracking=tracking, lut=lut, ts=ts, trace_set=trace_set)
    for j, name in enumerate(tracker_names):
        tracker = registry.build(name, tracker_specs[name], context)
        if hasattr(tracker, "record") and getattr(tracker, "adaptive", False):
            tracker.record = ("s4_hat",)
        out = tracker.run(real.y, init)
        eu = unwrapped_error(out.theta_d, real.theta_d)
        for kk, e in enumerate((wrap(eu), eu)):
            e2 = e**2
            sq[j, kk] = e2.sum(axis=0)
            sq2[j, kk] = (e2**2).sum(axis=0)
            ms[j, kk] = e2[:, steady].mean(axis=1)
        slips[j], events[j] = slip_counts(eu, hyst, settle)
        example[j] = eu[0]
        if "s4_hat" in out.extras:
            s4_hat[j] = out.extras["s4_hat"].mean(axis=0)
    ds = xr.Dataset(
        {
            "sq_sum": (("tracker", "kind", "time"), sq, {"long_name": "sum over trials of the squared phase error", "units": "rad2"}),
            "sq2_sum": (("tracker", "kind", "time"), sq2, {"long_name": "sum over trials of the 4th power of the phase error", "units": "rad4"}),
            "ms_steady": (("tracker", "kind", "trial"), ms, {"long_name": "per-trial mean square error over the steady-state window", "units": "rad2"}),
            "slips": (("tracker", "trial"), slips, {"long_name": "cycles slipped per trial", "units": "1"}),
            "slip_events": (("tracker", "trial"), events, {"long_name": "slip events per trial", "units": "1"}),
            "example_error": (("tracker", "time"), example, {"long_name": "unwrapped phase error of the first trial of the shard", "units": "rad"}),
            "example_trial": ((), int(real.trials[0])),
            "s4_true": (("time",), real.s4_t, {"long_name": "S4 of the CSM profile", "units": "1"}),
            "tau0_true": (("time",), real.tau0_t, {"long_name": "tau0 of the CSM profile", "units": "s"}),
            "s4_hat_mean": (("tracker", "time"), s4_hat, {"long_name": "mean over trials of the on-line S4 estimate (adaptive trackers)", "units": "1"}),
            "n_trials": ((), int(real.trials.size)),
        },
        coords={
            "tracker": list(tracker_names),
            "kind": list(KINDS),
            "trial": real.trials,
            "time": ("time", real.time, {"units": "s", "long_name": "time"}),
        },
    )
    ds.attrs.update(
        {
            "scenario": scenario_name,
            "steady_state_start_s": float(tracking["steady_state_start_s"]),
            "slip_hysteresis_rad": hyst,
            "slip_settle_s": float(tracking["slip_settle_s"]),
            "tracker_labels": tracker_labels(tracker_names, tracker_specs),
        }
    )
    return ds


def tracker_labels(names: Sequence[str], specs: Mapping[str, Mapping[str, Any]]) -> str:
    """Canonical JSON ``{name: plain-text label}`` (the ``tracker_labels`` attribute of results)."""
    return canonical_json({name: registry.label(name, specs[name]) for name in names})


def merge(shards: Sequence[xr.Dataset]) -> xr.Dataset:
    """Combine shards exactly and add the reduced statistics."""
    shards = sorted(shards, key=lambda d: int(d["example_trial"]))
    first = shards[0]
    n = int(sum(int(d["n_trials"]) for d in shards))
    out = xr.Dataset(
        {
            "sq_sum": sum(d["sq_sum"] for d in shards),
            "sq2_sum": sum(d["sq2_sum"] for d in shards),
            "ms_steady": xr.concat([d["ms_steady"] for d in shards], dim="trial"),
            "slips": xr.concat([d["slips"] for d in shards], dim="trial"),
            "slip_events": xr.concat([d["slip_events"] for d in shards], dim="trial"),
            "example_error": first["example_error"],
            "example_trial": first["example_trial"],
            "s4_true": first["s4_true"],
            "tau0_true": first["tau0_true"],
            "s4_hat_mean": sum(d["s4_hat_mean"] * int(d["n_trials"]) for d in shards) / n,
            "n_trials": n,
        }
    )
    out.attrs.update(first.attrs)
    trials = out["trial"].values
    if np.unique(trials).size != trials.size:
        raise ValueError("shards overlap: a trial index appears twice")
    rmse, lo, hi = rmse_with_ci(out["sq_sum"].values, out["sq2_sum"].values, n)
    attrs = {"units": "rad"}
    out["rmse"] = (("tracker", "kind", "time"), rmse, {**attrs, "long_name": "RMSE of theta_d over trials"})
    out["rmse_lo"] = (("tracker", "kind", "time"), lo, {**attrs, "long_name": "lower 95% limit of the RMSE"})
    out["rmse_hi"] = (("tracker", "kind", "time"), hi, {**attrs, "long_name": "upper 95% limit of the RMSE"})
    s, slo, shi = steady_rmse(out["ms_steady"].values, axis=-1)
    out["steady_rmse"] = (("tracker", "kind"), s, {**attrs, "long_name": "steady-state RMSE of theta_d"})
    out["steady_rmse_lo"] = (("tracker", "kind"), slo, attrs)
    out["steady_rmse_hi"] = (("tracker", "kind"), shi, attrs)
    for key in ("sq_sum", "sq2_sum", "slips", "slip_events", "ms_steady", "example_error", "s4_true", "s4_hat_mean"):
        out[key].attrs.update(first[key].attrs)
    return out
