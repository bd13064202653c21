"""Exact merge of Monte Carlo shards (:mod:`.runner`) into one result with its statistics.

Per-trial variables (including the guard's ``diverged_epoch`` and
``divergence_reason``) are concatenated over trials; per-time sums are added;
the on-line S4 mean is weighted by estimable trial-epochs (:func:`_s4_mean`).

Kept apart from the runner so that a merge job imports xarray and numpy only
(no tracker, no numba): with ~70 merges in the full DAG, the import time of
each job counts.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from ..io import provenance
from .metrics import rmse_with_ci, steady_rmse

MONITORS = ("phi3", "p", "weight", "T")  # on-line SAKF quantities averaged over trials (T: median)


def _s4_mean(shards: Sequence[xr.Dataset], n: int) -> xr.DataArray:
    """Trial-weighted mean of the shards' ``s4_hat_mean``; where a shard had non-estimable epochs
    (``s4_hat_estimable`` < 1) each shard is weighted by its estimable trial-epochs instead, and a shard
    without any adds nothing (its NaN mean does not turn the merged mean into NaN).  With every
    fraction 1 (or NaN: no S4 estimate) this is the plain trial-weighted formula, bit for bit."""
    plain = sum(d["s4_hat_mean"] * int(d["n_trials"]) for d in shards) / n
    if not all("s4_hat_estimable" in d for d in shards):
        return plain
    fracs = [d["s4_hat_estimable"] for d in shards]
    if all(bool(((f == 1.0) | f.isnull()).all()) for f in fracs):
        return plain
    weights = [f.fillna(0.0) * int(d["n_trials"]) for f, d in zip(fracs, shards)]
    num = sum((d["s4_hat_mean"].fillna(0.0) * w) for d, w in zip(shards, weights))
    den = sum(weights)
    return num / den.where(den > 0)  # NaN where nothing was estimable (and for trackers without an S4 estimate)


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
            "ms_total_steady": xr.concat([d["ms_total_steady"] for d in shards], dim="trial"),
            "slips_total": xr.concat([d["slips_total"] for d in shards], dim="trial"),
            "slip_events_total": xr.concat([d["slip_events_total"] for d in shards], dim="trial"),
            "time_in_lock": xr.concat([d["time_in_lock"] for d in shards], dim="trial"),
            "s4_hat_median": xr.concat([d["s4_hat_median"] for d in shards], dim="trial"),
            "example_error": first["example_error"],
            "example_trial": first["example_trial"],
            "s4_true": first["s4_true"],
            "tau0_true": first["tau0_true"],
            "s4_hat_mean": _s4_mean(shards, n),
            "n_trials": n,
        }
    )
    if "s4_hat_estimable" in first:
        out["s4_hat_estimable"] = sum(d["s4_hat_estimable"] * int(d["n_trials"]) for d in shards) / n
    for key in ("design_s4", "design_tau0"):
        if key in first:
            out[key] = first[key]
    for key in ("diverged_epoch", "divergence_reason"):
        if key in first:
            out[key] = xr.concat([d[key] for d in shards], dim="trial")
    optional = [k for k in ("jitter_discriminator", "jitter_tracking") if k in first]
    for key in optional:
        out[key] = xr.concat([d[key] for d in shards], dim="trial")
    for key in ("example_discriminator", "example_frequency", "example_frequency_true"):
        if key in first:
            out[key] = first[key]
    for m in MONITORS:
        key = f"{m}_mean"
        if key in first:
            if m != "T":
                out[key] = sum(d[key] * int(d["n_trials"]) for d in shards) / n
            else:  # a median does not merge: the first shard's, and the trials it covers say so (the SAKF monitor figure)
                out[key] = first[key].assign_attrs(median_trials=int(first["n_trials"]))
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
    s, slo, shi = steady_rmse(out["ms_total_steady"].values, axis=-1)
    out["steady_rmse_total"] = (("tracker",), s, {**attrs, "long_name": "steady-state RMSE of the wrapped total-phase error"})
    out["steady_rmse_total_lo"] = (("tracker",), slo, attrs)
    out["steady_rmse_total_hi"] = (("tracker",), shi, attrs)
    guard_keys = [k for k in ("s4_hat_estimable", "diverged_epoch", "divergence_reason") if k in first]
    for key in ("sq_sum", "sq2_sum", "slips", "slip_events", "ms_steady", "example_error", "s4_true", "s4_hat_mean", "ms_total_steady", "slips_total",
                "slip_events_total", "time_in_lock", *optional, *guard_keys):
        out[key].attrs.update(first[key].attrs)
    return out


def merged_result(shards: Sequence[xr.Dataset], run: Mapping[str, Any], inputs: Sequence[str]) -> xr.Dataset:
    """The result of an (experiment, scenario): its shards merged (:func:`.merge.merge`), with provenance and title."""
    result = merge(shards)
    result.attrs.update(provenance(config=run, seed=int(run["seed"]), inputs=list(inputs), extra={"experiment": run["experiment"]}))
    if "trace" in run["scenario"]:
        source = result.attrs.get("trace_source", "unknown")
        data = "SYNTHETIC SURROGATE scintillation trace" if source == "surrogate" else f"{source} scintillation trace"
    else:
        data = "synthetic CSM data" if run["scenario"].get("segments") else "no scintillation"
    result.attrs["title"] = f"{run['experiment']}: {run['scenario_name']} ({int(result['n_trials'])} trials, {data})"
    return result
