"""Exact merge of Monte Carlo shards (:mod:`.runner`) into one result with its statistics.

Kept apart from the runner so that a merge job imports xarray and numpy only
(no tracker, no numba): with ~70 merges in the full DAG, the import time of
each job counts (issue 14).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr

from .metrics import rmse_with_ci, steady_rmse

MONITORS = ("phi3", "p", "weight", "T")  # on-line SAKF quantities averaged over trials (T: median)


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
            "s4_hat_mean": sum(d["s4_hat_mean"] * int(d["n_trials"]) for d in shards) / n,
            "n_trials": n,
        }
    )
    optional = [k for k in ("jitter_discriminator", "jitter_tracking") if k in first]
    for key in optional:
        out[key] = xr.concat([d[key] for d in shards], dim="trial")
    for key in ("example_discriminator", "example_frequency", "example_frequency_true"):
        if key in first:
            out[key] = first[key]
    for m in MONITORS:
        key = f"{m}_mean"
        if key in first:
            out[key] = sum(d[key] * int(d["n_trials"]) for d in shards) / n if m != "T" else first[key]  # T: the first shard's median
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
    for key in ("sq_sum", "sq2_sum", "slips", "slip_events", "ms_steady", "example_error", "s4_true", "s4_hat_mean", "ms_total_steady", "slips_total",
                "slip_events_total", "time_in_lock", *optional):
        out[key].attrs.update(first[key].attrs)
    return out
