"""Figures of Zhao, Khanafseh & Pervan for the receiver on our jammed dataset: Figs. 4, 6, 7, 9, 10, 11, the ablation and the C/N0 sweep.

All read ``results/zhao_jamming/receiver.nc``
(:mod:`scintrack.experiments.gps_positioning`); Figs. 6 and 9 also read the
dataset (its true carrier Doppler), the sweep reads one file per jammed C/N0.
Every title says the data are synthetic (``conventions.data_title``).

Choices a reader could question:

* **Tracking time series** (Figs. 6, 9, 10) are one Monte Carlo trial
  (``zhao_receiver.figure_trial``) of the first satellite, as the paper shows
  one run; the figures say which.  The out-of-lock spans shaded there are the
  receiver's own lock detector on that trial (``zhao_receiver.lock``: running
  mean of |phase error| over ``window_s`` above ``threshold_rad``).
* **Reconstructed carrier frequency** (Figs. 6, 9): the paper plots the
  frequency the loop tracks; ours is the dataset's true carrier Doppler plus
  the tracker's frequency error (the loop tracks the residual after the
  ephemeris-predicted Doppler; adding the prediction back gives the carrier
  frequency at 0 Hz IF).  The error is drawn beside it, because at a scale of
  kHz a 0.2 Hz error is invisible.
* **Lost lock** (Fig. 9): once the PLL's frequency error leaves
  +-:data:`FREQ_LOCK_HZ` (half the inverse of a 20-ms bit: a 20-ms coherent
  sum has lost 3.9 dB there) and never comes back, the loop has run away; its
  frequency traces are cut there and the point is marked
  (``conventions.until_lock_lost``), instead of drawing a runaway of kHz.
* **Clean case** (Figs. 6, 7): the first 120 s of the jammed run, before the
  onset; the paper ran a separate 4-minute clean scenario.  The figures say so.
* **Positions** (Figs. 7, 11): every trial's error at each epoch is summarised
  by the mean over trials and the 5-95 % band across trials; one
  representative trial (the one whose 3D RMS error over the segment is the
  median of all trials) is drawn over them, and each panel states the
  statistics over all trials beside the paper's one-run numbers.
* **Phase RMSE of different trackers** (ablation, sweep): the Costas PLL's
  error is wrapped modulo pi (no lock: pi/(2 sqrt 3) = 0.907 rad), the MM
  filter's modulo 2 pi (no lock: pi/sqrt 3 = 1.81 rad); each RMSE is divided
  by its own no-lock level, so one axis holds both and 1 means "no lock".
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ...experiments.lock_detector import lock_state
from ...experiments.metrics import mean_ci
from ...pipeline import paths
from ..registry import Verdict, figure
from ..tables.paper_values import ZHAO_ENU
from ..tables.zhao_jamming import sweep_summary
from .common import new_figure
from .conventions import (
    MIN_FONT_PT,
    NO_LOCK_RMSE_2PI,
    NO_LOCK_RMSE_PI,
    data_title,
    figure_legend,
    log_ticks,
    mark_lock_lost,
    no_lock_level,
    until_lock_lost,
)

if TYPE_CHECKING:
    import xarray as xr

PAPER = "zhao_jamming"
SEC_RX = "Zhao et al.: receiver through jamming"
SYNTHETIC = data_title("synthetic SKYDEL-like")
LABELS = {"pll": "Costas PLL (1 ms)", "mm_none": "MM KF, no bit prediction", "mm_mask": "MM KF, upload-robust mask", "mm_iode": "MM KF, IODE check"}
COLORS = {"pll": "tab:blue", "mm_none": "tab:orange", "mm_mask": "tab:green", "mm_iode": "tab:red"}
# zhao_receiver.pll_lock: the PLL with lock detector, frequency hold and FLL re-pull (scintrack.trackers.pll_lock)
LABELS["pll_fll"] = "Costas PLL, hold/FLL"
COLORS["pll_fll"] = "tab:purple"
#: the pll_fll variant's frequency while its own detector reads out of lock (hold / FLL re-pull)
FLL_OUT = "tab:brown"
_RX = {"receiver": paths.ZHAO_RECEIVER}
#: a frequency error beyond this (Hz) for good is a loop that has run away: 1 / (2 x 20 ms)
FREQ_LOCK_HZ = 25.0
#: the paper's Fig. 4 claim: share of the bits predictable through an upload, averaged over 25 frames
PAPER_PREDICTABLE = 0.38
#: the paper's Fig. 9/10 numbers: PLL frequency "up to 20 Hz" when lost, MM frequency error "average variance 3 Hz"
PAPER_PLL_FREQ_HZ = 20.0
PAPER_MM_FREQ_HZ = 3.0
#: the paper's C/N0 during jamming (dB-Hz)
PAPER_JAMMED_CN0 = 15.0
CLEAN_NOTE = "clean case = first {onset:g} s of the jammed run (the paper ran a separate 4-minute clean scenario)"
OUT_OF_LOCK = {"color": "tab:red", "alpha": 0.13, "lw": 0}


def _lock_kwargs(config) -> dict:
    return {"lock": {k: float(v) for k, v in config["zhao_receiver"]["lock"].items()}}


def _rx_and_dataset(config) -> dict[str, str]:
    return {"receiver": paths.ZHAO_RECEIVER, "dataset": paths.gps_dataset_path(config)}


def no_lock_rmse(tracker: str) -> float:
    """The RMSE of ``tracker``'s phase error without lock (its wrapping interval's)."""
    return NO_LOCK_RMSE_PI if tracker in ("pll", "pll_fll") else NO_LOCK_RMSE_2PI


def _onset(ax, res: xr.Dataset) -> None:
    ax.axvline(float(res.attrs["jammer_onset_s"]), color="0.3", lw=0.9, ls=":")


def _example(res: xr.Dataset, tracker: str, what: str, prn_index: int = 0):
    t = res["time_bit"].values
    return t, res[f"example_{what}"].sel(tracker=tracker).isel(prn=prn_index).values


def _locked(error: np.ndarray, t: np.ndarray, lock: dict) -> np.ndarray:
    ts = float(np.median(np.diff(t)))
    return lock_state(error, ts, float(lock["threshold_rad"]), float(lock["window_s"]))


def _shade_out_of_lock(ax, t: np.ndarray, locked: np.ndarray) -> None:
    ax.fill_between(t, 0, 1, where=~locked, transform=ax.get_xaxis_transform(), step="mid", **OUT_OF_LOCK)


def _lock_handle(lock: dict):
    import matplotlib.patches as mpatches

    return mpatches.Patch(label=f"out of lock (receiver's detector: {lock['window_s']:g}-s mean |phase error| > {lock['threshold_rad']:g} rad)",
                          **OUT_OF_LOCK)


def _true_doppler(dataset: xr.Dataset, prn: int, t: np.ndarray) -> np.ndarray:
    k = int(np.flatnonzero(dataset["prn"].values == prn)[0])
    return np.interp(t, dataset["receive_time"].isel(sv=k).values, dataset["doppler"].isel(sv=k).values)


def _pll_fll_traces(res: xr.Dataset, keep: np.ndarray, t: np.ndarray, truth: np.ndarray, ax2, ax3):
    """The ``pll_fll`` variant (``zhao_receiver.pll_lock``) beside the bare PLL in Figs. 6 and 9: its reconstructed
    frequency and frequency error, in its colour while its own detector reads in lock and in :data:`FLL_OUT`
    while it holds / re-pulls (lost lock drawn as such, not as an error).  Returns (frequency error, share of
    the span out of lock), or None without the variant."""
    if "pll_fll" not in res["tracker"].values:
        return None
    _, ferr = _example(res, "pll_fll", "frequency")
    ferr = ferr[keep]
    own = (res["example_pll_fll_locked"].isel(prn=0).values[keep] > 0) if "example_pll_fll_locked" in res else np.ones(len(t), dtype=bool)
    for ok, color in ((own, COLORS["pll_fll"]), (~own, FLL_OUT)):
        part = np.where(ok, ferr, np.nan)
        ax2.plot(t, truth + part, lw=0.7, color=color)
        ax3.plot(t, part, lw=0.6, color=color)
    return ferr, float(np.mean(~own))


def _pll_figure(res: xr.Dataset, dataset: xr.Dataset, lock: dict, clean: bool, title: str):
    """Phase error, reconstructed carrier frequency beside the truth, and the frequency error of the PLL (one trial, first satellite)."""
    from matplotlib.lines import Line2D

    fig, (ax1, ax2, ax3) = new_figure(3, 1, figsize=(7.0, 7.6))
    onset = float(res.attrs["jammer_onset_s"])
    t, e = _example(res, "pll", "phase")
    _, ferr = _example(res, "pll", "frequency")
    prn = int(res["prn"].values[0])
    keep = t <= onset if clean else np.ones_like(t, dtype=bool)
    t, e, ferr = t[keep], e[keep], ferr[keep]
    truth = _true_doppler(dataset, prn, t)
    locked = _locked(e, t, lock)
    ferr_cut, t_lost = until_lock_lost(t, ferr, FREQ_LOCK_HZ)
    ax1.plot(t, np.degrees(e), lw=0.4, color="tab:blue")
    ax1.set_ylabel("phase error [deg]\n(Costas, mod 180)")
    ax1.set_ylim(-95, 95)
    ax1.set_yticks([-90, -45, 0, 45, 90])
    ax2.plot(t, truth, lw=1.6, color="0.6", label="true carrier Doppler")
    ax2.plot(t, truth + ferr_cut, lw=0.7, color="tab:orange", label="PLL reconstructed carrier frequency")
    ax2.set_ylabel("carrier frequency\nat 0 Hz IF [Hz]")
    ax3.plot(t, ferr_cut, lw=0.6, color="tab:orange")
    ax3.set_ylabel("frequency error [Hz]\n(reconstructed - true)")
    ax3.set_xlabel("time [s]")
    if t_lost is not None:
        k = int(np.searchsorted(t, t_lost)) - 1
        t_mark = round(t_lost, 1)
        mark_lock_lost(ax2, t_mark, float(truth[k] + ferr[k]), color="k", label="loop ran away")
        mark_lock_lost(ax3, t_mark, float(ferr[k]), color="k", label="loop ran away")
    for ax in (ax1, ax2, ax3):
        if not locked.all():
            _shade_out_of_lock(ax, t, locked)
        if not clean:
            _onset(ax, res)
    fll = _pll_fll_traces(res, keep, t, truth, ax2, ax3)
    shown = ferr_cut if fll is None else np.concatenate([ferr_cut, fll[0]])
    if np.isfinite(shown).any():
        lo, hi = np.nanmin(shown), np.nanmax(shown)
        pad = 0.15 * max(hi - lo, 0.2)
        ax3.set_ylim(lo - pad, hi + pad * 2.5)  # room above for the "ran away" label
    handles = [Line2D([], [], color="0.6", lw=1.6), Line2D([], [], color="tab:orange", lw=0.9)]
    labels = ["true carrier Doppler", "PLL: reconstructed carrier frequency / its error"]
    if not clean:
        handles.append(Line2D([], [], color="0.3", lw=0.9, ls=":"))
        labels.append(f"jammer onset ({onset:g} s)")
    if not locked.all():
        h = _lock_handle(lock)
        handles.append(h)
        labels.append(h.get_label())
    if t_lost is not None:
        handles.append(Line2D([], [], color="k", marker="x", ls="none", mew=2))
        labels.append(f"loop ran away: frequency error beyond ±{FREQ_LOCK_HZ:g} Hz for good (trace cut)")
    if fll is not None:
        handles += [Line2D([], [], color=COLORS["pll_fll"], lw=0.9), Line2D([], [], color=FLL_OUT, lw=0.9)]
        labels += [f"{LABELS['pll_fll']}: in lock (its own detector)",
                   f"{LABELS['pll_fll']}: out of lock, frequency held / FLL re-pull ({100 * fll[1]:.0f}% of the span)"]
    trial = int(res.attrs["figure_trial"])
    sub = f"PRN {prn}, trial {trial}, 3rd-order Costas PLL at 1 ms" + (" (phase error, shading: the bare PLL)" if fll is not None else "")
    if clean:
        sub += "\n" + CLEAN_NOTE.format(onset=onset)
    fig.suptitle(f"{title}\n{sub}\n({SYNTHETIC})", fontsize=9)
    fig.tight_layout()
    figure_legend(fig, handles, labels, ncol=2, fontsize=7.5)
    return fig


def _pll_freq_std(res: xr.Dataset, segment: str) -> np.ndarray:
    return np.sqrt(res[f"sv_freq_var_{segment}"].sel(tracker="pll").values)


def verdict_fig06(receiver, dataset, lock=None):
    """Reproduced when the PLL keeps lock through the clean part in every trial and satellite: every clean
    phase RMSE below half the Costas no-lock level (the paper gives no number for Fig. 6, only a locked loop)."""
    rmse = receiver["sv_phase_rmse_clean"].sel(tracker="pll").values
    fstd = _pll_freq_std(receiver, "clean")
    ok = bool(np.all(rmse < 0.5 * NO_LOCK_RMSE_PI))
    n = f"{int(receiver.attrs['n_trials'])} trials x {receiver.sizes['prn']} SVs"
    return Verdict("reproduced" if ok else "differs",
                   f"clean PLL phase RMSE at most {np.max(rmse):.3f} rad ({n}; no lock {NO_LOCK_RMSE_PI:.2f} rad), frequency error std "
                   f"{np.mean(fstd):.2f} Hz; paper: a locked PLL at 46 dB-Hz, no number")


@figure("zhao_fig06", "fig06_pll_clean", paper=PAPER, section=SEC_RX, inputs=_rx_and_dataset, kwargs=_lock_kwargs,
        number="Fig. 6", claim="Without interference the Costas PLL tracks the carrier: small phase error and a steady reconstructed frequency",
        tables=(), verdict=verdict_fig06)
def zhao_fig06(receiver, dataset, lock=None):
    lock = lock or {"threshold_rad": 0.5, "window_s": 1.0}
    return _pll_figure(receiver, dataset, lock, True, "Fig. 6: PLL output, clean signal")


def verdict_fig09(receiver, dataset, lock=None):
    """The paper: the PLL loses lock under jamming (phase error up to 90 deg) and its reconstructed frequency
    varies by up to 20 Hz.  Reproduced when the PLL is in lock less than 10 % of the jammed time AND its
    jammed frequency-error std is within a factor 2 of 20 Hz; differs when it loses lock but its frequency
    runs away (std beyond that); not reproduced when it keeps lock."""
    in_lock = float(np.mean(receiver["sv_in_lock_jammed"].sel(tracker="pll").values))
    fstd = float(np.median(_pll_freq_std(receiver, "jammed")))
    rmse = float(np.mean(receiver["sv_phase_rmse_jammed"].sel(tracker="pll").values))
    if in_lock >= 0.1:
        status = "not reproduced"
    else:
        status = "reproduced" if fstd <= 2 * PAPER_PLL_FREQ_HZ else "differs"
    lock_words = "as in the paper" if in_lock < 0.1 else "the paper's PLL lost lock"
    runaway = " (the loop runs away)" if status == "differs" else ""
    return Verdict(status, f"PLL in lock {100 * in_lock:.1f}% of jammed time, phase RMSE {rmse:.3f} rad (no lock {NO_LOCK_RMSE_PI:.3f}), {lock_words}; "
                           f"jammed frequency error std {fstd:.0f} Hz (median over trials x SVs){runaway} vs paper 'up to {PAPER_PLL_FREQ_HZ:g} Hz'"
                           + _pll_fll_verdict(receiver))


def _pll_fll_verdict(receiver) -> str:
    """The same rule on the ``pll_fll`` variant (``zhao_receiver.pll_lock``), as a sentence; empty without it."""
    if "pll_fll" not in receiver["tracker"].values:
        return ""
    in_lock = float(np.mean(receiver["sv_in_lock_jammed"].sel(tracker="pll_fll").values))
    fstd = np.sqrt(receiver["sv_freq_var_jammed"].sel(tracker="pll_fll").values)
    ok = in_lock < 0.1 and float(np.median(fstd)) <= 2 * PAPER_PLL_FREQ_HZ
    return (f". {LABELS['pll_fll']} (a receiver's loop): in lock {100 * in_lock:.1f}% of jammed time, frequency error std "
            f"{float(np.median(fstd)):.1f} Hz (median; max {float(np.max(fstd)):.1f}): by the same rule "
            f"{'reproduced' if ok else 'not reproduced'}")


@figure("zhao_fig09", "fig09_pll_jammed", paper=PAPER, section=SEC_RX, inputs=_rx_and_dataset, kwargs=_lock_kwargs,
        number="Fig. 9", claim="Under 15 dB-Hz jamming the PLL loses lock: its phase error saturates at 90 deg and its frequency wanders by up to 20 Hz",
        tables=(), verdict=verdict_fig09)
def zhao_fig09(receiver, dataset, lock=None):
    lock = lock or {"threshold_rad": 0.5, "window_s": 1.0}
    return _pll_figure(receiver, dataset, lock, False,
                       f"Fig. 9: PLL output under jamming ({float(receiver.attrs['cn0_jammed_dbhz']):.1f} dB-Hz from "
                       f"{float(receiver.attrs['jammer_onset_s']):g} s)")


def _mm_trackers(res: xr.Dataset) -> list[str]:
    return [str(n) for n in res["tracker"].values if n != "pll"]


def verdict_fig10(receiver, lock=None):
    """The paper: the MM filter tracks through jamming with a frequency error of "average variance 3 Hz" (read as a
    std of 3 Hz).  Reproduced when the IODE-check filter is in lock at least 90 % of the jammed time and its jammed
    frequency-error std (mean over trials and satellites) is within a factor 2 of 3 Hz; differs when it keeps lock
    with a std outside that; not reproduced when it loses lock."""
    tr = "mm_iode" if "mm_iode" in receiver["tracker"].values else _mm_trackers(receiver)[-1]
    in_lock = float(np.mean(receiver["sv_in_lock_jammed"].sel(tracker=tr).values))
    fstd = float(np.mean(np.sqrt(receiver["sv_freq_var_jammed"].sel(tracker=tr).values)))
    if in_lock < 0.9:
        status = "not reproduced"
    else:
        status = "reproduced" if PAPER_MM_FREQ_HZ / 2 <= fstd <= 2 * PAPER_MM_FREQ_HZ else "differs"
    return Verdict(status, f"{LABELS.get(tr, tr)} in lock {100 * in_lock:.1f}% of jammed time (as in the paper); frequency error std "
                           f"{fstd:.3f} Hz vs paper '{PAPER_MM_FREQ_HZ:g} Hz' ({int(receiver.attrs['n_trials'])} trials x {receiver.sizes['prn']} SVs)")


@figure("zhao_fig10", "fig10_mm_jammed", paper=PAPER, section=SEC_RX, inputs=lambda c: _RX, kwargs=_lock_kwargs,
        number="Fig. 10", claim="The MM Kalman filter keeps estimating clock phase and carrier frequency through jamming (frequency error about 3 Hz)",
        tables=(), verdict=verdict_fig10)
def zhao_fig10(receiver, lock=None):
    """One row per MM variant (small multiples: the three nearly coincide), clock phase error left, frequency error right."""
    from matplotlib.lines import Line2D

    lock = lock or {"threshold_rad": 0.5, "window_s": 1.0}
    names = _mm_trackers(receiver)
    fig, axes = new_figure(len(names), 2, figsize=(9.0, 2.1 * len(names) + 1.2), squeeze=False)
    onset = float(receiver.attrs["jammer_onset_s"])
    shaded = False
    flim = 0.0
    for row, name in zip(axes, names):
        t, e = _example(receiver, name, "phase")
        _, f = _example(receiver, name, "frequency")
        locked = _locked(e, t, lock)
        jam = t >= onset
        color = COLORS.get(name, "k")
        row[0].plot(t, np.degrees(e), lw=0.4, color=color)
        row[1].plot(t, f, lw=0.5, color=color)
        row[0].set_ylim(-185, 185)
        row[0].set_yticks([-180, -90, 0, 90, 180])
        row[0].set_ylabel("phase error [deg]")
        row[1].set_ylabel("freq. error [Hz]")
        rms = np.degrees(np.sqrt(np.mean(e[jam] ** 2)))
        row[0].set_title(f"{LABELS.get(name, name)}: jammed RMSE {rms:.0f} deg, in lock {100 * np.mean(locked[jam]):.0f}%", fontsize=8)
        row[1].set_title(f"{LABELS.get(name, name)}: jammed std {np.std(f[jam]):.3f} Hz", fontsize=8)
        settled = t > min(1.0, float(t[len(t) // 2]))
        flim = max(flim, float(np.nanmax(np.abs(f[settled]))))
        for ax in row:
            _onset(ax, receiver)
            if not locked.all():
                _shade_out_of_lock(ax, t, locked)
                shaded = True
    for ax in axes[:, 1] if np.isfinite(flim) and flim > 0 else []:
        ax.set_ylim(-1.15 * flim, 1.15 * flim)  # the first second (filter settling from its initial covariance) may go beyond
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    fig.suptitle(f"Fig. 10: MM Kalman filter under jamming ({float(receiver.attrs['cn0_jammed_dbhz']):.1f} dB-Hz), one row per bit-prior strategy\n"
                 f"PRN {int(receiver['prn'].values[0])}, trial {int(receiver.attrs['figure_trial'])}; error wrapped to (-180, 180] deg ({SYNTHETIC})",
                 fontsize=9)
    fig.tight_layout()
    handles = [Line2D([], [], color="0.3", lw=0.9, ls=":")]
    labels = [f"jammer onset ({onset:g} s)"]
    h = _lock_handle(lock)
    handles.append(h)
    labels.append(h.get_label() + ("" if shaded else ": never in this trial"))
    figure_legend(fig, handles, labels, ncol=2, fontsize=7.5)
    return fig


def representative_trial(res: xr.Dataset, tracker: str, segment: str) -> int:
    """The trial whose 3D RMS position error over ``segment`` is the median over trials (the lower middle one for an even count)."""
    rms = res[f"err3d_rms_{segment}"].sel(tracker=tracker).values
    order = np.argsort(rms, kind="stable")
    return int(res["trial"].values[order[(len(order) - 1) // 2]])


def _position_figure(res: xr.Dataset, tracker: str, segment: str, title: str):
    """ENU error over time: mean and 5-95 % band over all trials, one representative trial, the statistics in each title."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    fig, axes = new_figure(3, 1, figsize=(7.0, 7.4))
    onset = float(res.attrs["jammer_onset_s"])
    t = res["time"].values
    keep = t <= onset if segment == "clean" else np.ones_like(t, dtype=bool)
    enu_all = res["enu_error"].sel(tracker=tracker).values.astype(float)  # (trial, time, axis)
    rep = representative_trial(res, tracker, segment)
    rep_i = int(np.flatnonzero(res["trial"].values == rep)[0])
    n = int(res.sizes["trial"])
    mean_t = np.mean(enu_all, axis=0)
    lo_t, hi_t = np.percentile(enu_all, [5, 95], axis=0)
    for ax, j, name in zip(axes, range(3), ("east", "north", "up")):
        ax.fill_between(t[keep], lo_t[keep, j], hi_t[keep, j], color="tab:blue", alpha=0.18, lw=0)
        ax.plot(t[keep], enu_all[rep_i, keep, j], lw=0.7, color="tab:blue")
        ax.plot(t[keep], mean_t[keep, j], lw=1.2, color="k", ls="--")
        ax.set_ylabel(f"{name} error [m]")
        if segment == "jammed":
            _onset(ax, res)
        m, mlo, mhi = mean_ci(res[f"enu_mean_{segment}"].sel(tracker=tracker).values[:, j])
        s = float(np.mean(res[f"enu_std_{segment}"].sel(tracker=tracker).values[:, j]))
        pm, ps = ZHAO_ENU.get((segment, "mean", name)), ZHAO_ENU.get((segment, "std", name))
        paper = f"; paper (1 run): |mean| {pm:g} m, std {ps:g} m" if pm is not None else ""
        ax.set_title(f"{segment} part, all {n} trials: mean {m:.2f} m [{mlo:.2f}, {mhi:.2f}], std {s:.1f} m{paper}", fontsize=8)
        top = max(abs(lo_t[keep, j]).max(), abs(hi_t[keep, j]).max(), abs(enu_all[rep_i, keep, j]).max())
        ax.set_ylim(-1.1 * top, 1.1 * top)
    axes[-1].set_xlabel("time [s]")
    note = ("\n" + CLEAN_NOTE.format(onset=onset)) if segment == "clean" else ""
    fig.suptitle(f"{title}, {LABELS.get(tracker, tracker)} carrier aiding; 1 Hz least squares, 4 satellites{note}\n({SYNTHETIC})", fontsize=9)
    fig.tight_layout()
    handles = [Patch(color="tab:blue", alpha=0.18, lw=0), Line2D([], [], color="k", lw=1.2, ls="--"), Line2D([], [], color="tab:blue", lw=0.7)]
    labels = [f"5-95% of the {n} trials at each epoch", "mean over trials",
              f"trial {rep} (median 3D RMS error of the {segment} part)"]
    if segment == "jammed":
        handles.append(Line2D([], [], color="0.3", lw=0.9, ls=":"))
        labels.append(f"jammer onset ({onset:g} s)")
    figure_legend(fig, handles, labels, ncol=2, fontsize=7.5)
    return fig


def _position_verdict(res: xr.Dataset, tracker: str, segment: str) -> Verdict:
    stds = [float(np.mean(res[f"enu_std_{segment}"].sel(tracker=tracker).values[:, j])) for j in range(3)]
    means = [float(np.mean(res[f"enu_mean_{segment}"].sel(tracker=tracker).values[:, j])) for j in range(3)]
    pstd = [ZHAO_ENU[(segment, "std", a)] for a in ("east", "north", "up")]
    pmean = [ZHAO_ENU[(segment, "mean", a)] for a in ("east", "north", "up")]
    ok = all(p / 2 <= s <= 2 * p for s, p in zip(stds, pstd))
    fmt = "/".join
    return Verdict("reproduced" if ok else "differs",
                   f"{segment} ENU std {fmt(f'{s:.1f}' for s in stds)} m vs paper {fmt(f'{p:g}' for p in pstd)} m; mean "
                   f"{fmt(f'{m:.1f}' for m in means)} m vs paper |{fmt(f'{p:g}' for p in pmean)}| m ({LABELS.get(tracker, tracker)}, "
                   f"mean over {int(res.attrs['n_trials'])} trials)")


def verdict_fig07(receiver):
    """Reproduced when the clean ENU std (mean over trials of each trial's std) is within a factor 2 of the paper's on every
    axis; the means are reported beside the paper's (one run, magnitudes only) but not part of the rule."""
    return _position_verdict(receiver, "pll", "clean")


@figure("zhao_fig07", "fig07_position_clean", paper=PAPER, section=SEC_RX, inputs=lambda c: _RX,
        number="Fig. 7", claim="Clean PLL-aided positions stay near the truth: ENU mean errors 3.9/0.2/0.5 m, std 13/23/50 m",
        tables=("zhao_table_enu",), verdict=verdict_fig07)
def zhao_fig07(receiver):
    return _position_figure(receiver, "pll", "clean", "Fig. 7: position errors, clean signal")


def _best(receiver) -> str:
    return "mm_iode" if "mm_iode" in receiver["tracker"].values else str(receiver["tracker"].values[-1])


def verdict_fig11(receiver):
    """Reproduced when the jammed ENU std (mean over trials of each trial's std, IODE-check MM aiding) is within a factor 2
    of the paper's on every axis; the means are reported beside the paper's (one run, magnitudes only) but not part of the rule."""
    return _position_verdict(receiver, _best(receiver), "jammed")


@figure("zhao_fig11", "fig11_position_jammed", paper=PAPER, section=SEC_RX, inputs=lambda c: _RX,
        number="Fig. 11", claim="MM-aided positions through 15 dB-Hz jamming: ENU mean 5/1.8/1.9 m, std 16/32/63 m, a little worse than clean",
        tables=("zhao_table_enu",), verdict=verdict_fig11)
def zhao_fig11(receiver):
    return _position_figure(receiver, _best(receiver), "jammed", "Fig. 11: position errors through jamming")


def verdict_fig04(receiver):
    """Reproduced when the share of predicted bits in the map's next frame is within 10 percentage points of the
    paper's 38 % (the paper averages 25 frames; the map is one frame)."""
    frac = float(np.mean(receiver["prediction_next"].values != 0))
    ok = abs(frac - PAPER_PREDICTABLE) <= 0.10
    return Verdict("reproduced" if ok else "differs",
                   f"{100 * frac:.0f}% of the next frame predictable (PRN {int(receiver.attrs['prediction_map_prn'])}, one frame) vs paper "
                   f"~{100 * PAPER_PREDICTABLE:.0f}% (average over 25 frames)")


@figure("zhao_fig04", "fig04_bit_prediction_map", paper=PAPER, section=SEC_RX, inputs=lambda c: _RX,
        number="Fig. 4", claim="From the last five decoded subframes an upload-robust mask predicts about 38% of the next frame's bits",
        tables=(), verdict=verdict_fig04)
def zhao_fig04(receiver):
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    fig, (ax1, ax2) = new_figure(1, 2, figsize=(8.0, 6.6))
    last = receiver["prediction_last"].values
    nxt = receiver["prediction_next"].values
    colors = ["black", "0.7", "white"]
    cmap = ListedColormap(colors)
    for ax, data, title in ((ax1, last, "last 5 subframes (decoded)"), (ax2, nxt, "next 5 subframes: predictable bits")):
        ax.imshow(data, cmap=cmap, vmin=-1, vmax=1, aspect="auto", interpolation="nearest")
        for sf in range(1, 5):
            ax.axhline(10 * sf - 0.5, color="tab:red", lw=0.8)
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("bit in word")
        ax.set_xticks([0, 9, 19, 29])
        ax.set_xticklabels(["1", "10", "20", "30"])
        ax.set_yticks([4.5 + 10 * k for k in range(5)])
        ax.set_yticklabels([f"SF{k + 1}" for k in range(5)])
        ax.grid(False)
    frac = float(np.mean(nxt != 0))
    fig.suptitle(f"Fig. 4: bit prediction map, PRN {int(receiver.attrs['prediction_map_prn'])}, upload-robust mask "
                 f"({100 * frac:.0f}% of the next frame predictable)\nrows: the 10 words of each subframe (red lines between subframes) ({SYNTHETIC})",
                 fontsize=9)
    fig.tight_layout()
    handles = [Patch(facecolor="black", edgecolor="0.4"), Patch(facecolor="white", edgecolor="0.4"), Patch(facecolor="0.7", edgecolor="0.4")]
    figure_legend(fig, handles, ["level -1 (bit 1)", "level +1 (bit 0)", "not predicted (prior 1/2)"], ncol=3, fontsize=8)
    return fig


def _upload_prns(receiver) -> list[int]:
    return [int(p.split()[1]) for p in str(receiver.attrs["uploads"]).split(", ") if p.startswith("PRN")]


def verdict_ablation(receiver):
    """No paper figure (the paper has no ablation).  The line gives the normalised jammed phase RMSE of each tracker
    (RMSE over its own no-lock level, 1 = no lock) and the IODE check's cost on the satellite with an upload."""
    upload = _upload_prns(receiver)
    prns = [int(p) for p in receiver["prn"].values]
    parts = []
    for tr in receiver["tracker"].values:
        v = receiver["sv_phase_rmse_jammed"].sel(tracker=tr).values / no_lock_rmse(str(tr))
        parts.append(f"{tr} {np.mean(v):.2f}")
    text = "jammed phase RMSE / no-lock level: " + ", ".join(parts)
    if upload and "mm_iode" in receiver["tracker"].values:
        idx = [i for i, p in enumerate(prns) if p in upload]
        rest = [i for i, p in enumerate(prns) if p not in upload]
        v = receiver["sv_phase_rmse_jammed"].sel(tracker="mm_iode").values
        text += f"; IODE check {np.mean(v[rest]):.2f} rad without upload vs {np.mean(v[idx]):.2f} rad on PRN {', '.join(map(str, upload))} (upload)"
    return Verdict("no paper figure", text)


@figure("zhao_ablation", "ablation", paper=PAPER, section=SEC_RX, inputs=lambda c: _RX,
        number=None, claim="No paper figure: the paper argues that bit prediction and the IODE check let the MM filter track through jamming",
        tables=("zhao_table_ablation",), verdict=verdict_ablation)
def zhao_ablation(receiver):
    """Every trial's jammed-part statistics per tracker, satellites with and without an upload during jamming apart."""
    metrics = [("sv_phase_rmse_jammed", "phase RMSE / no-lock RMSE (jammed)"), ("sv_in_lock_jammed", "share of jammed time in lock"),
               ("sv_bit_error_jammed", "share of wrong bit decisions (jammed)"), ("err3d_rms_jammed", "3D position RMS error (jammed) [m]")]
    fig, axes = new_figure(2, 2, figsize=(8.6, 6.8))
    trackers = [str(t) for t in receiver["tracker"].values]
    x = np.arange(len(trackers))
    upload_prns = _upload_prns(receiver)
    group_colors = ("tab:blue", "tab:orange")
    handles, labels = {}, {}
    for ax, (key, label) in zip(axes.ravel(), metrics):
        v = receiver[key].values.astype(float)
        if key == "sv_phase_rmse_jammed":
            v = v / np.array([no_lock_rmse(t) for t in trackers])[:, None, None]
        if "prn" in receiver[key].dims:
            groups = [("no upload", [i for i, p in enumerate(receiver["prn"].values) if p not in upload_prns]),
                      ("upload during jamming", [i for i, p in enumerate(receiver["prn"].values) if p in upload_prns])]
            for j, (name, idx) in enumerate(groups):
                if not idx:
                    continue
                m, lo, hi = mean_ci(v[:, idx, :].reshape(len(trackers), -1), axis=1)
                sats = ", ".join(str(int(receiver["prn"].values[i])) for i in idx)
                h = ax.errorbar(x + 0.15 * (2 * j - 1), m, yerr=[m - lo, hi - m], fmt="o", ms=4, capsize=3, color=group_colors[j])
                handles[name], labels[name] = h, f"{name} (PRN {sats})"
        else:
            m, lo, hi = mean_ci(v, axis=1)
            h = ax.errorbar(x, m, yerr=[m - lo, hi - m], fmt="s", ms=4, capsize=3, color="k")
            handles["all"], labels["all"] = h, "all satellites (one fix per epoch)"
        if key == "sv_phase_rmse_jammed":
            no_lock_level(ax, 1.0, label="no lock (each tracker's own level)")
            ax.set_ylim(0, 1.15)
        elif key == "sv_bit_error_jammed":
            no_lock_level(ax, 0.5, label="no information: 0.5")
            ax.set_ylim(-0.02, 0.58)
        elif key == "sv_in_lock_jammed":
            ax.set_ylim(-0.03, 1.08)
        if key.startswith("err3d"):
            ax.set_yscale("log")
            log_ticks(ax)
        ax.set_xticks(x)
        ax.set_xticklabels([LABELS.get(t, t).replace(", ", ",\n").replace(" (", "\n(") for t in trackers], fontsize=MIN_FONT_PT)
        ax.set_title(label, fontsize=9)
    fig.suptitle(f"Ablation: {int(receiver.attrs['n_trials'])} trials of the 4-minute scenario, mean and 95% interval; jammed at "
                 f"{float(receiver.attrs['cn0_jammed_dbhz']):.1f} dB-Hz\nuploads: {receiver.attrs['uploads']}. No-lock RMSE: PLL (mod pi) "
                 f"{NO_LOCK_RMSE_PI:.3f} rad, MM (mod 2 pi) {NO_LOCK_RMSE_2PI:.2f} rad ({SYNTHETIC})", fontsize=9)
    fig.tight_layout()
    order = [k for k in ("no upload", "upload during jamming", "all") if k in handles]
    figure_legend(fig, [handles[k] for k in order], [labels[k] for k in order], ncol=3, fontsize=8)
    return fig


def _sweep_inputs(config) -> dict[str, str]:
    return {f"cn0_{i}": paths.zhao_sweep_point(c) for i, c in enumerate(config["zhao_receiver"]["cn0_sweep"]["cn0_dbhz"])}


def _lock_cn0(s: dict, j: int, share: float = 0.9) -> float | None:
    """The lowest C/N0 of the sweep from which tracker ``j`` is in lock at least ``share`` of the jammed time."""
    ok = s["in_lock_jammed"]["mean"][j] >= share
    for i in range(len(ok)):
        if ok[i:].all():
            return float(s["cn0"][i])
    return None


def verdict_sweep(*points):
    """No paper figure (the paper has no sweep; it states the PLL cannot hold lock at 15 dB-Hz).  The line gives, per
    tracker, the lowest swept C/N0 from which it is in lock at least 90 % of the jammed time, and the PLL's share
    of time in lock at the point nearest 15 dB-Hz."""
    s = sweep_summary(points)
    parts = []
    for j, tr in enumerate(s["trackers"]):
        c = _lock_cn0(s, j)
        parts.append(f"{tr} >= {c:g} dB-Hz" if c is not None else f"{tr} never")
    i15 = int(np.argmin(np.abs(s["cn0"] - PAPER_JAMMED_CN0)))
    jp = s["trackers"].index("pll") if "pll" in s["trackers"] else 0
    return Verdict("no paper figure", "in lock >= 90% of jammed time: " + ", ".join(parts) +
                   f"; PLL in lock {100 * s['in_lock_jammed']['mean'][jp, i15]:.1f}% at {s['cn0'][i15]:g} dB-Hz (paper: PLL cannot hold lock at 15 dB-Hz)")


@figure("zhao_sweep", "cn0_sweep", paper=PAPER, section=SEC_RX, inputs=_sweep_inputs,
        number=None, claim="No paper figure: the paper states that at 15 dB-Hz the PLL cannot keep phase lock while the MM filter can",
        tables=("zhao_table_cn0_sweep",), verdict=verdict_sweep)
def zhao_sweep(*points):
    s = sweep_summary(points)
    fig, axes = new_figure(2, 2, figsize=(9.0, 7.0))
    axes = axes.ravel()
    panels = (("phase_rmse_jammed", "phase RMSE / no-lock RMSE (jammed)"), ("in_lock_jammed", "share of jammed time in lock"),
              ("bit_error_jammed", "share of wrong bit decisions (jammed)"),
              ("freq_std_jammed", "frequency error (jammed): median, bars = quartiles"))  # the frequency Figs. 6, 9, 10 draw per trial
    handles = []
    for ax, (key, label) in zip(axes, panels):
        for j, tr in enumerate(s["trackers"]):
            if key == "freq_std_jammed":
                m, lo, hi = (s[key][w][j] for w in ("median", "q25", "q75"))
            else:
                scale = no_lock_rmse(tr) if key == "phase_rmse_jammed" else 1.0
                m, lo, hi = (s[key][w][j] / scale for w in ("mean", "lo", "hi"))
            h = ax.errorbar(s["cn0"] + 0.12 * (j - (len(s["trackers"]) - 1) / 2), m, yerr=[m - lo, hi - m], marker="o", ms=3, capsize=2, lw=1,
                            color=COLORS.get(tr), label=LABELS.get(tr, tr))
            if ax is axes[0]:
                handles.append(h)
        ax.set_xlabel("jammed C/N$_0$ [dB-Hz]")
        if len(s["cn0"]) >= 2:
            ax.set_xticks(s["cn0"])
            ax.set_xticklabels([f"{c:g}" for c in s["cn0"]], fontsize=MIN_FONT_PT + 0.5)
        else:  # one point: automatic ticks around it
            ax.set_xlim(s["cn0"][0] - 2.5, s["cn0"][0] + 2.5)
        ax.set_title(label, fontsize=9)
    axes[3].set_yscale("log")
    log_ticks(axes[3])
    axes[3].set_ylabel("std of the frequency error [Hz]")
    no_lock_level(axes[0], 1.0, label="no lock (each tracker's own level)")
    axes[0].set_ylim(0, 1.25)
    axes[1].set_ylim(-0.03, 1.08)
    no_lock_level(axes[2], 0.5, label="no information: 0.5")
    axes[2].set_ylim(-0.02, 0.6)
    p0 = points[0]
    fig.suptitle(f"Where each receiver variant breaks: jammed C/N0 sweep, {int(p0.attrs['n_trials'])} trials x {p0.sizes['prn']} satellites, "
                 f"mean and 95% interval (frequency: median and quartiles)\nno-lock RMSE: PLL (mod pi) {NO_LOCK_RMSE_PI:.3f} rad, MM (mod 2 pi) {NO_LOCK_RMSE_2PI:.2f} rad; "
                 f"markers offset slightly in C/N0 to stay apart ({SYNTHETIC})", fontsize=9)
    fig.tight_layout()
    figure_legend(fig, handles, [h.get_label() for h in handles], ncol=4, fontsize=8)
    return fig
