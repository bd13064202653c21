"""One satellite channel of the jamming receiver as a labelled result: per-trial metrics, RMSE(t), example series, pseudoranges.

Runs :func:`scintrack.experiments.gps_receiver.channel` over the trials in
batches and keeps what the figures and tables need, not the raw 1-ms series:

* per tracker (``pll`` and each MM variant) and trial: wrapped phase-error
  RMSE and frequency-error variance in the clean and the jammed part,
  loss-of-lock events and the fraction of jammed time in lock (detector:
  :func:`.gps_prompts.lock_state`, running mean of |error| over
  ``lock.window_s`` above ``lock.threshold_rad``), the fraction of wrong bit
  decisions in the jammed part, the number of predicted and of wrongly
  predicted bits;
* per tracker and 20-ms epoch: the phase-error RMSE over trials;
* per tracker, for ``figure_trial``: phase and frequency error series;
* per tracker, trial and position epoch: the measured pseudorange
  ``c (arrival estimate - transmit time)`` interpolated to the common
  receiver time, with the DLL's code error (with ``code_phase: sample``,
  rounded to the sample grid of the recording: :func:`sample_quantised`).

The PLL's errors are modulo pi (Costas); the MM filter's modulo 2 pi.  With
``zhao_receiver.pll_lock`` the tracker ``pll_fll`` (the PLL with lock
detector, frequency hold and FLL re-pull) follows ``pll`` with the same
metrics (modulo pi), and ``example_pll_fll_locked`` holds its own detector's
state for ``figure_trial``.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..signals.gps import ephemeris
from ..signals.gps.orbit import C_LIGHT
from . import gps_bit_prediction
from . import gps_prompts as gp
from .gps_receiver import channel, prior_sources

CHIP_S = 1.0 / 1.023e6


def _navigation(path: str | Path) -> tuple[tuple[ephemeris.Ephemeris, ...], ephemeris.NavHeader]:
    """(data sets, header) of the navigation file, read once per job and file version: a sweep point runs every
    channel on the same file (the records are frozen dataclasses, so sharing them is safe)."""
    try:
        st = Path(path).stat()
    except OSError:  # let the reader give its own error for a missing file
        return tuple(ephemeris.load(path)), ephemeris.read_header(path)
    return _read_navigation(str(path), st.st_mtime_ns, st.st_size)


@functools.lru_cache(maxsize=2)
def _read_navigation(path: str, mtime_ns: int, size: int) -> tuple[tuple[ephemeris.Ephemeris, ...], ephemeris.NavHeader]:
    return tuple(ephemeris.load(path)), ephemeris.read_header(path)


def sample_quantised(pseudorange_m: np.ndarray, sample_rate_hz: float) -> np.ndarray:
    """Pseudoranges whose code phase is read at the integer sample of the recording (``zhao_receiver.code_phase: sample``).

    A receiver that counts samples forms the transmit time of the code at a
    sample instant from the whole number of samples since the code epoch:
    the delay ``rho / c`` is known to the sample, ``T_s = 1 / f_s``, so the
    pseudorange is ``rho_q = (c / f_s) round(rho f_s / c)`` (one step, 24 m at
    12.5 MS/s; uniform error of std ``c / (f_s sqrt(12))`` = 6.9 m as the
    Doppler sweeps the code across the sample grid).  The 1-ms code period is
    a whole number of samples at 12.5 MS/s, so rounding the whole delay and
    rounding the code phase within the period are the same.
    """
    step = C_LIGHT / float(sample_rate_hz)
    return step * np.round(np.asarray(pseudorange_m, dtype=float) / step)


def _code_phase_rate(params: Mapping[str, Any]) -> float | None:
    """The sampling rate the pseudoranges are quantised to, or None (continuous code phase, the DLL's NCO)."""
    mode = params["receiver"].get("code_phase", "continuous")
    if mode == "continuous":
        return None
    if mode != "sample" or not params.get("sample_rate_hz"):
        raise ValueError(f"zhao_receiver.code_phase: {mode!r} needs 'continuous', or 'sample' with the recording's "
                         "gps_jamming.iq.sample_rate_hz in the params (scintrack.pipeline.params)")
    return float(params["sample_rate_hz"])


def _trackers(params: Mapping[str, Any]) -> list[str]:
    pll_fll = ["pll_fll"] if params["receiver"].get("pll_lock") is not None else []  # zhao_receiver.pll_lock
    return ["pll", *pll_fll, *params["receiver"]["variants"]]


def _metrics(err: np.ndarray, ferr: np.ndarray, jammed: np.ndarray, lock: Mapping[str, Any]) -> dict[str, np.ndarray]:
    ts = gp.BIT_MS * gp.CODE_PERIOD_S
    locked = gp.lock_state(err, ts, float(lock["threshold_rad"]), float(lock["window_s"]))
    def per_trial(fun, x):  # one 1-D reduction per trial: numpy sums the rows of a 2-D array in an order that depends
        return np.array([fun(row) for row in x])  # on how many rows it has, so a trial's value would follow trial_batch

    return {
        "phase_rmse_clean": np.sqrt(per_trial(np.mean, err[:, ~jammed] ** 2)),
        "phase_rmse_jammed": np.sqrt(per_trial(np.mean, err[:, jammed] ** 2)),
        "freq_var_clean": per_trial(np.var, ferr[:, ~jammed]),
        "freq_var_jammed": per_trial(np.var, ferr[:, jammed]),
        "lol_events": gp.loss_of_lock_events(locked),
        "in_lock_jammed": np.mean(locked[:, jammed], axis=1),
    }


def start_prediction(ds: xr.Dataset, k: int, ephs, header):
    """Upload-robust prediction of satellite ``k`` over [first bit, t0 + 30 s]: the frames the Fig. 4 map needs."""
    from ..signals.gps import bit_prediction

    week, t0 = int(ds.attrs["gps_week"]), float(ds.attrs["t_start_sow"])
    t_first = t0 + float(ds["nav_bit_time"].values[0])
    return bit_prediction.robust_prediction(ephs, header, int(ds["prn"].values[k]), week, t_first + 1e-6, t0 + 30.0)


def _prediction_map(ds: xr.Dataset, k: int, ephs, header, robust=None) -> tuple[np.ndarray, np.ndarray]:
    """Fig. 4 arrays: the last complete frame before the start and the upload-robust prediction of the next.

    ``robust``: the channel's own upload-robust prediction (:func:`gps_receiver.prior_sources`), which starts
    at the same frame and runs to the scenario's end + 30 s; the map needs its frames up to the one holding
    the scenario start, and those do not depend on where the span ends (every alternative history of a later
    frame boundary, an upload cut in there, sends the scheduled set before it, and the parity chain restarts
    at every subframe), so it gives the map of :func:`start_prediction` (``tests/test_gps_receiver.py``).
    ``None`` (no MM variant uses a prediction): :func:`start_prediction`.
    """
    from ..signals.gps import bit_prediction

    if robust is None:
        robust = start_prediction(ds, k, ephs, header)
    j = int(np.sum(ds["nav_bit_time"].values < 0.0) // 1500)  # frame containing the scenario start
    last = ds["nav_bits"].isel(sv=k).values[(j - 1) * 1500 : j * 1500]
    priors = bit_prediction.BitPredictor("mask", robust).priors(j)
    return bit_prediction.prediction_map(last, priors)


def channel_result(ds: xr.Dataset, prn: int, params: Mapping[str, Any], ephemerides_path: str | Path,
                   log: Callable[..., None] = lambda *a: None, cn0_jammed_dbhz: float | None = None, trials: int | None = None,
                   trial_batch: int | None = None, prediction: xr.Dataset | None = None) -> xr.Dataset:
    """One satellite channel over ``trials`` (default ``receiver.trials``) Monte Carlo trials, ``trial_batch`` at a time
    (default: all at once).  The batch bounds the memory only: every output is the same bits for any batch.
    ``prediction``: the dataset's bit predictions (:func:`.gps_bit_prediction.predictions`, the rule
    ``zhao_bit_prediction``); by default this channel's is computed here (the same arrays)."""
    k = int(np.flatnonzero(ds["prn"].values == prn)[0])
    ephs, header = _navigation(ephemerides_path)
    rc = params["receiver"]
    n_trials = int(rc["trials"] if trials is None else trials)
    batch = max(1, int(n_trials if trial_batch is None else trial_batch))
    names = _trackers(params)
    onset = float(ds.attrs["jammer_onset_s"])
    rt = ds["receive_time"].isel(sv=k).values
    pr_true = ds["pseudorange"].isel(sv=k).values
    if rc["corrections"]:
        # the receiver's models are the ones the dataset used (Klobuchar from the broadcast alpha/beta, the
        # tropospheric model): they cancel the delays exactly, i.e. a perfectly modelled atmosphere
        pr_true = pr_true - ds["iono"].isel(sv=k).values - ds["tropo"].isel(sv=k).values
    rate = float(rc["position_rate_hz"])
    fs_code = _code_phase_rate(params)
    t_pos = np.arange(np.ceil(rt[0] * rate), np.floor(rt[-1] * rate) + 1) / rate
    fig_trial = int(rc["figure_trial"])
    per_trial: dict[str, list[np.ndarray]] = {}
    sq_sum: dict[str, np.ndarray] = {}
    example: dict[str, np.ndarray] = {}
    pseudo: dict[str, list[np.ndarray]] = {name: [] for name in names}
    t20 = jammed = None
    robust = None if prediction is None else gps_bit_prediction.prediction_of(prediction, ds, k)
    sources = prior_sources(ds, k, rc["variants"], ephs, header, float(rc["prior_eps"]), robust=robust)
    for b0 in range(0, n_trials, batch):
        trials_b = list(range(b0, min(n_trials, b0 + batch)))
        out = channel(ds, k, params, trials_b, sources, cn0_jammed_dbhz=cn0_jammed_dbhz)
        start = int(out["start_epoch"])
        n_bits = out["pll_phase_error"].shape[1]
        if t20 is None:
            t20 = rt[start : start + n_bits * gp.BIT_MS : gp.BIT_MS]
            jammed = t20 >= onset
        true_bit = (out["true_level"] < 0).astype(np.int8)
        for name in names:
            err, ferr = out[f"{name}_phase_error"], out[f"{name}_frequency_error"]
            m = _metrics(err, ferr, jammed, rc["lock"])
            if name in ("pll", "pll_fll"):
                # Costas decisions up to one global sign, fixed on the clean part
                lvl = out[f"{name}_level"]
                sign = np.sign(np.sum(lvl[:, ~jammed] * out["true_level"][~jammed], axis=1, keepdims=True))
                wrong = (lvl * sign) != out["true_level"][None, :]
                m.update(predicted=np.zeros(len(trials_b)), prediction_wrong=np.zeros(len(trials_b)))
            else:
                wrong = out[f"{name}_bit_error"]
                m.update(predicted=np.sum(out[f"{name}_predicted"][:, jammed], axis=1),
                         prediction_wrong=np.sum(out[f"{name}_prediction_wrong"][:, jammed], axis=1))
            m["bit_error_jammed"] = np.mean(wrong[:, jammed], axis=1)
            m["bit_error_clean"] = np.mean(wrong[:, ~jammed], axis=1)
            for key, v in m.items():
                per_trial.setdefault(f"{name}:{key}", []).append(np.asarray(v, dtype=float))
            sq = sq_sum.setdefault(name, np.zeros(err.shape[1]))
            for row in err:  # trial by trial, in trial order: the same sum whatever the batch (trial_batch is a memory setting)
                sq += row * row
            if b0 <= fig_trial < b0 + len(trials_b):
                i = fig_trial - b0
                example[f"{name}:phase"] = err[i]
                example[f"{name}:frequency"] = ferr[i]
                example[f"{name}:bit_error"] = wrong[i].astype(np.int8)
                if name == "pll_fll":  # its own detector's state (frequency hold / FLL re-pull while False)
                    example["pll_fll:locked"] = out["pll_fll_locked"][i].astype(np.int8)
            # pseudorange at the common receiver times: arrival estimate = true arrival - code error
            dtau = out[f"{name}_code_error_chips"]
            pr_meas = pr_true[None, :] - C_LIGHT * CHIP_S * dtau
            pr_pos = np.stack([np.interp(t_pos, rt, row) for row in pr_meas])
            pseudo[name].append(pr_pos if fs_code is None else sample_quantised(pr_pos, fs_code))
        log("PRN %d: trials %d-%d done", prn, trials_b[0], trials_b[-1])
        del true_bit
    metric_keys = sorted({key.split(":", 1)[1] for key in per_trial})
    data = {
        key: (("tracker", "trial"), np.array([np.concatenate(per_trial[f"{n}:{key}"]) for n in names]))
        for key in metric_keys
    }
    data["rmse_t"] = (("tracker", "time"), np.array([np.sqrt(sq_sum[n] / n_trials) for n in names]), {"units": "rad"})
    for what, units in (("phase", "rad"), ("frequency", "Hz"), ("bit_error", "1")):
        data[f"example_{what}"] = (("tracker", "time"), np.array([example[f"{n}:{what}"] for n in names]), {"units": units, "trial": fig_trial})
    if "pll_fll:locked" in example:
        data["example_pll_fll_locked"] = (("time",), example["pll_fll:locked"],
                                          {"units": "1", "trial": fig_trial, "long_name": "pll_fll: its own lock detector in lock (1) or holding / re-pulling (0)"})
    data["pseudorange"] = (("tracker", "trial", "pos_time"), np.array([np.concatenate(pseudo[n]) for n in names]), {"units": "m"})
    shared = next((src.robust for src in sources.values() if src.robust is not None), None)
    last, nxt = _prediction_map(ds, k, ephs, header, shared)
    data["prediction_last"] = (("word", "bit_in_word"), last)
    data["prediction_next"] = (("word", "bit_in_word"), nxt)
    res = xr.Dataset(
        data,
        coords={"tracker": ("tracker", names), "trial": ("trial", np.arange(n_trials)), "time": ("time", t20, {"units": "s"}),
                "pos_time": ("pos_time", t_pos, {"units": "s", "long_name": "receiver time of the position epochs"})},
    )
    res.attrs.update(prn=int(prn), jammer_onset_s=onset, cn0_jammed_dbhz=float(ds.attrs["cn0_jammed_dbhz"] if cn0_jammed_dbhz is None else cn0_jammed_dbhz),
                     dataset_version=str(ds.attrs["dataset_version"]), source="synthetic", n_trials=n_trials,
                     error_wrap="pll: modulo pi (Costas); mm_*: modulo 2 pi" + ("; pll_fll: modulo pi" if "pll_fll" in names else ""))
    return res
