"""The upload-robust bit prediction of every satellite of a jammed dataset, computed once per dataset.

The MM receiver's ``mm_mask`` and ``mm_iode`` variants start from the
upload-robust prediction of each satellite's stream
(:func:`scintrack.signals.gps.bit_prediction.robust_prediction`) over the
scenario's frames, from the first navigation bit to 30 s after the end
(:func:`span`).  It depends on the navigation file and on the dataset's
timing only: not on the C/N0, the trials or the receiver settings.  So the
rule ``zhao_bit_prediction`` writes it once (:func:`predictions`) and every
channel job and every point of the C/N0 sweep reads it
(:func:`prediction_of`) instead of computing it (about 1 CPU-s per
satellite, a quarter of a sweep point).

Layout: ``bits`` and ``mask`` (``sv``, ``nav_bit``; int8, the mask 1 where
every alternative history transmits the same bit), per satellite its ``prn``
and ``n_alternatives``; the attributes ``gps_week``, ``t0_sow`` (start of the
first frame, s of the week) and the span it was computed for, which
:func:`prediction_of` checks against the dataset it is used with.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from ..signals.gps import bit_prediction


def span(ds: xr.Dataset) -> tuple[int, float, float]:
    """(GPS week, t_start, t_end) in s of the week of the prediction a channel of ``ds`` needs."""
    week, t0 = int(ds.attrs["gps_week"]), float(ds.attrs["t_start_sow"])
    t_first = t0 + float(ds["nav_bit_time"].values[0])
    return week, t_first + 1e-6, t0 + float(ds.attrs["duration_s"]) + 30.0


def channel_prediction(ds: xr.Dataset, k: int, ephs, header) -> bit_prediction.RobustPrediction:
    """The upload-robust prediction of satellite ``k`` of ``ds`` over :func:`span`."""
    week, t_start, t_end = span(ds)
    return bit_prediction.robust_prediction(ephs, header, int(ds["prn"].values[k]), week, t_start, t_end)


def predictions(ds: xr.Dataset, ephs, header) -> xr.Dataset:
    """:func:`channel_prediction` of every satellite of ``ds`` as one dataset (module docstring)."""
    preds = [channel_prediction(ds, k, ephs, header) for k in range(ds.sizes["sv"])]  # one span: the same frames for all
    week, t_start, t_end = span(ds)
    return xr.Dataset(
        {
            "bits": (("sv", "nav_bit"), np.stack([p.bits for p in preds]).astype(np.int8), {"long_name": "scheduled transmitted bit (no upload)"}),
            "mask": (("sv", "nav_bit"), np.stack([p.mask for p in preds]).astype(np.int8),
                     {"long_name": "1 where every alternative history transmits the same bit (the bit is predicted)"}),
            "n_alternatives": ("sv", np.array([p.n_alternatives for p in preds], dtype=np.int64), {"long_name": "histories compared"}),
        },
        coords={"prn": ("sv", np.array([p.prn for p in preds], dtype=np.int64))},
        attrs={"gps_week": week, "t0_sow": int(preds[0].t0), "span_start_sow": t_start, "span_end_sow": t_end},
    )


def prediction_of(pred: xr.Dataset, ds: xr.Dataset, k: int) -> bit_prediction.RobustPrediction:
    """The prediction of satellite ``k`` of ``ds`` from :func:`predictions` (refused if made for another span or satellite set)."""
    made_for, needed = (int(pred.attrs["gps_week"]), float(pred.attrs["span_start_sow"]), float(pred.attrs["span_end_sow"])), span(ds)
    if made_for != needed:
        raise ValueError(f"the bit prediction was computed for (week, start, end) = {made_for}, the dataset needs {needed}; rerun zhao_bit_prediction")
    prn = int(ds["prn"].values[k])
    where = np.flatnonzero(pred["prn"].values == prn)
    if where.size != 1:
        raise ValueError(f"the bit prediction holds no satellite PRN {prn}; rerun zhao_bit_prediction")
    j = int(where[0])
    return bit_prediction.RobustPrediction(
        prn=prn, week=made_for[0], t0=int(pred.attrs["t0_sow"]), bits=pred["bits"].values[j].astype(np.int8),
        mask=pred["mask"].values[j].astype(bool), n_alternatives=int(pred["n_alternatives"].values[j]),
    )
