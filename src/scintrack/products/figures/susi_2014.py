"""Figures of Susi, Andreotti & Aquino 2014 (KF PLLs at 1 ms): Figs. 3-8 and the SAKF monitor.

* Figs. 3 and 6: S4 and Phi60 over 60-s windows, truth (noise-free trace)
  and as a receiver measures them (``results/susi_2014/indices``);
* Fig. 4: the discriminator output of the PLL, AKF PLL and SAKF PLL, one
  trial, high latitude, with a zoom on the largest excursion;
* Figs. 5 and 8: the phase jitter per 60-s window, mean over trials with its
  95% band: the chapter's discriminator jitter and the jitter of the true
  tracking error;
* Fig. 7: carrier Doppler estimates against the truth, one trial,
  equatorial, with the estimate-minus-truth panel;
* SAKF monitor: the SAKF's on-line Phi3, power-law slope p and strength T
  (means over trials) beside their noise-free values, and the gain weight w
  of eq. (12), for both scenarios.

The high-latitude scintillation is always a SYNTHETIC SURROGATE; the
equatorial one is too unless the JRC traces are configured: every title says
which (``trace_source`` of the results).  Time series of one trial are the
stored 10-ms means of the 1-ms quantities.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ...experiments.metrics import mean_with_ci
from ...labels import tex, tracker_labels
from ...pipeline import paths
from ..registry import figure
from ..tables.susi_2014 import (
    CHAPTER,
    METRICS,
    PAPER,
    SECTION,
    experiment_scenarios,
    jitter_trackers,
    scenario_is_surrogate,
    source_text,
    steady_windows,
    ts_ms,
    window_length_s,
)
from .common import new_figure

if TYPE_CHECKING:
    import xarray as xr

HIGH, EQUATORIAL = "susi_high_latitude", "susi_equatorial"
COLOURS = {"susi_pll": "C0", "susi_akf": "C1", "susi_sakf": "C2"}
WHERE = {HIGH: "high latitude", EQUATORIAL: "equatorial"}


def _colour(name: str, k: int) -> str:
    return COLOURS.get(name, f"C{k}")


def _label(ds: xr.Dataset, name: str) -> str:
    return tex(tracker_labels(ds).get(name, name))


def _where(ds: xr.Dataset) -> str:
    return WHERE.get(str(ds.attrs.get("scenario")), str(ds.attrs.get("scenario")))


def _cond(ds: xr.Dataset) -> str:
    return f"C/N$_0$ = {float(ds.attrs['cn0_dbhz']):g} dB-Hz, $T_s$ = {ts_ms(ds)} ms"


def _block_ms(ds: xr.Dataset) -> str:
    return f"{int(ds.attrs.get('stats_block_epochs', 1)) * float(ds.attrs['ts']) * 1000:g}"


def _steady_start(ds: xr.Dataset) -> float:
    return float(ds.attrs["steady_state_start_s"])


# --- Figs. 3 and 6: scintillation indices -----------------------------------------------------


def indices_figure(ind: xr.Dataset, fig_no: int):
    fig, (ax1, ax2) = new_figure(2, 1, figsize=(6.4, 5.4), sharex=True)
    t = ind["window"].values
    half = float(ind.attrs["window_s"]) / 2
    mon = str(ind.attrs.get("monitor_tracker", "PLL"))
    for ax, key, name in ((ax1, "s4", "$S_4$"), (ax2, "phi60", r"$\Phi_{60}$ [rad]")):
        ax.errorbar(t, ind[f"{key}_true"].values, xerr=half, fmt="o-", ms=4, lw=1.0, capsize=0, color="0.2", label="truth (noise-free trace)")
        rx = "prompts, thermal noise removed" if key == "s4" else f"{mon} carrier phase, dynamics removed, causal high-pass"
        ax.errorbar(t, ind[f"{key}_receiver"].values, xerr=half, fmt="s--", ms=4, lw=1.0, capsize=0, color="tab:red", label=f"receiver ({rx})")
        ax.set_ylabel(name)
        ax.set_ylim(bottom=0)
        ax.legend(loc="best", fontsize=7)
    ax2.set_xlabel("time [s] (bars: the window)")
    fig.suptitle(f"Fig. {fig_no}: $S_4$ and $\\Phi_{{60}}$ over {float(ind.attrs['window_s']):g}-s windows, {_where(ind)} scenario\n"
                 f"{source_text(ind)}\n{_cond(ind)}; receiver: trial {int(ind.attrs['trial'])}", fontsize=9)
    fig.tight_layout()
    return fig


def _indices_inputs(scenario: str):
    return lambda c: {"indices": paths.susi_indices_path(scenario)}


def _surrogate(*scenarios: str):
    return lambda c: any(scenario_is_surrogate(c, sc) for sc in scenarios)


@figure("susi_fig03", "fig03_indices_high_latitude", paper=PAPER, section=SECTION, inputs=_indices_inputs(HIGH), surrogate=_surrogate(HIGH))
def susi_fig03(indices):
    return indices_figure(indices, 3)


@figure("susi_fig06", "fig06_indices_equatorial", paper=PAPER, section=SECTION, inputs=_indices_inputs(EQUATORIAL), surrogate=_surrogate(EQUATORIAL))
def susi_fig06(indices):
    return indices_figure(indices, 6)


# --- Fig. 4: discriminator output ------------------------------------------------------------


def _zoom_span(t: np.ndarray, v: np.ndarray, start: float, length: float) -> tuple[float, float]:
    """``length`` seconds centred on the largest |v| after ``start``, inside the run."""
    after = t >= start
    if not after.any():
        after = np.ones_like(t, dtype=bool)
    k = np.flatnonzero(after)[int(np.nanargmax(np.abs(np.where(np.isfinite(v[after]), v[after], 0))))]
    lo = min(max(t[k] - length / 2, t[0]), max(t[-1] - length, t[0]))
    return float(lo), float(lo + length)


def discriminator_figure(res: xr.Dataset, fig_no: int):
    trackers = jitter_trackers(res)
    t = res["time"].values
    ss = _steady_start(res)
    fig, axes = new_figure(len(trackers) + 1, 1, figsize=(6.4, 1.55 * len(trackers) + 3.2))
    data = {tr: res["example_discriminator"].sel(tracker=tr).values for tr in trackers}
    lim = 1.05 * max(float(np.nanmax(np.abs(v))) for v in data.values())
    for k, (ax, tr) in enumerate(zip(axes, trackers)):
        v = data[tr]
        std = float(np.nanstd(v[t >= ss]))
        ax.plot(t, v, lw=0.4, color=_colour(tr, k))
        ax.set_ylim(-lim, lim)
        ax.set_ylabel("[rad]")
        ax.set_title(f"{_label(res, tr)}: std after {ss:g} s = {std:.3f} rad", fontsize=8)
        ax.axvline(ss, color="0.4", lw=0.8, ls=":")
    axes[len(trackers) - 1].set_xlabel("time [s]")
    length = min(5.0, float(t[-1] - t[0]) / 10)
    lo, hi = _zoom_span(t, data[trackers[0]], ss, length)
    zoom = axes[-1]
    keep = (t >= lo) & (t <= hi)
    for k, tr in enumerate(trackers):
        zoom.plot(t[keep], data[tr][keep], lw=0.9, color=_colour(tr, k), label=_label(res, tr))
        axes[k].axvspan(lo, hi, color="0.85", zorder=0)
    zoom.set_xlabel("time [s]")
    zoom.set_ylabel("[rad]")
    zoom.set_title(f"zoom on the largest {_label(res, trackers[0])} excursion (grey span above)", fontsize=8)
    zoom.legend(loc="upper right", ncol=3, fontsize=7)
    fig.suptitle(f"Fig. {fig_no}: discriminator output (phase error), {_where(res)} scenario, trial {int(res['example_trial'])}\n"
                 f"{_block_ms(res)}-ms means of the {ts_ms(res)}-ms output; {_cond(res)}\n{source_text(res)}", fontsize=9)
    fig.tight_layout()
    return fig


def _result_inputs(scenario: str):
    return lambda c: {"result": paths.exp_result(CHAPTER, scenario)}


@figure("susi_fig04", "fig04_discriminator_high_latitude", paper=PAPER, section=SECTION, inputs=_result_inputs(HIGH), surrogate=_surrogate(HIGH))
def susi_fig04(result):
    return discriminator_figure(result, 4)


# --- Figs. 5 and 8: jitter per window ----------------------------------------------------------


def jitter_figure(res: xr.Dataset, fig_no: int):
    fig, axes = new_figure(2, 1, figsize=(6.4, 6.0), sharex=True)
    w = res["window"].values
    length = window_length_s(res)
    trackers = jitter_trackers(res)
    first = w[steady_windows(res)][0] - length / 2
    titles = {"discriminator": "discriminator jitter (the chapter's phase jitter)",
              "tracking": r"tracking-error jitter: std of wrap($\hat\theta - \theta_d - \theta_s$)"}
    for ax, (metric, var) in zip(axes, METRICS.items()):
        for k, tr in enumerate(trackers):
            m, lo, hi = mean_with_ci(res[var].sel(tracker=tr).values, axis=0)
            dx = (k - (len(trackers) - 1) / 2) * 0.02 * length
            ax.errorbar(w + dx, m, yerr=[m - lo, hi - m], fmt="o-", ms=4, lw=1.0, capsize=2, color=_colour(tr, k), label=_label(res, tr))
            ax.fill_between(w, lo, hi, color=_colour(tr, k), alpha=0.15, lw=0)
        if first > w[0] - length / 2:
            ax.axvspan(w[0] - length / 2, first, color="0.9", zorder=0, label="transient window (not in the tables)")
        ax.set_ylabel("jitter [rad]")
        ax.set_title(titles[metric], fontsize=9)
        ax.legend(loc="best", fontsize=7)
    axes[-1].set_xlabel(f"time [s] (centre of the {length:g}-s window)")
    fig.suptitle(f"Fig. {fig_no}: phase jitter per {length:g}-s window, {_where(res)} scenario\n"
                 f"mean over {int(res['n_trials'])} trials with 95% band; {_cond(res)}\n{source_text(res)}", fontsize=9)
    fig.tight_layout()
    return fig


@figure("susi_fig05", "fig05_jitter_high_latitude", paper=PAPER, section=SECTION, inputs=_result_inputs(HIGH), surrogate=_surrogate(HIGH))
def susi_fig05(result):
    return jitter_figure(result, 5)


@figure("susi_fig08", "fig08_jitter_equatorial", paper=PAPER, section=SECTION, inputs=_result_inputs(EQUATORIAL), surrogate=_surrogate(EQUATORIAL))
def susi_fig08(result):
    return jitter_figure(result, 8)


# --- Fig. 7: carrier Doppler --------------------------------------------------------------------


TRUTH_SMOOTH_S = 0.1  # display: the true Doppler averaged over 0.1 s (the clock's white FM is not trackable)


def doppler_figure(res: xr.Dataset, fig_no: int):
    from scipy.ndimage import uniform_filter1d

    fig, axes = new_figure(3, 1, figsize=(6.4, 7.8))
    t = res["time"].values
    ss = _steady_start(res)
    truth = res["example_frequency_true"].values
    smooth = uniform_filter1d(truth, size=max(int(round(TRUTH_SMOOTH_S / (t[1] - t[0]))), 1), mode="nearest")
    line = float(res.attrs["fd0_hz"]) + float(res.attrs["fr_hz_s"]) * t
    trackers = [str(tr) for tr in res["tracker"].values if np.isfinite(res["example_frequency"].sel(tracker=tr).values).any()]
    length = min(10.0, float(t[-1] - t[0]) / 10)
    lo = min(ss, float(t[-1]) - length)
    keep = (t >= lo) & (t <= lo + length)
    after = t >= ss
    axes[0].plot(t, truth, lw=0.6, color="0.6", label=f"truth ({_block_ms(res)}-ms means)")
    axes[0].plot(t, smooth, lw=1.4, color="0.1", label=f"truth ({TRUTH_SMOOTH_S:g}-s mean)")
    axes[1].plot(t[keep], (truth - line)[keep], lw=0.6, color="0.6", label=f"truth ({_block_ms(res)}-ms means)")
    axes[1].plot(t[keep], (smooth - line)[keep], lw=1.6, color="0.1", label=f"truth ({TRUTH_SMOOTH_S:g}-s mean)")
    diffs = []
    for k, tr in enumerate(trackers):
        f = res["example_frequency"].sel(tracker=tr).values
        c = _colour(tr, k)
        rms = float(np.sqrt(np.nanmean((f - smooth)[after] ** 2)))
        rms_raw = float(np.sqrt(np.nanmean((f - truth)[after] ** 2)))
        axes[0].plot(t, f, lw=0.6, color=c, label=_label(res, tr))
        axes[1].plot(t[keep], (f - line)[keep], lw=0.9, color=c, label=_label(res, tr))
        axes[2].plot(t, f - smooth, lw=0.5, color=c, label=f"{_label(res, tr)}: RMS after {ss:g} s = {rms:.3g} Hz ({rms_raw:.3g} Hz vs {_block_ms(res)}-ms truth)")
        diffs.append((f - smooth)[after])
    axes[0].axvspan(t[keep][0], t[keep][-1], color="0.85", zorder=0)
    axes[0].set_ylabel("carrier Doppler [Hz]")
    axes[1].set_ylabel("Doppler $-$ ($f_{d0} + f_r t$) [Hz]")
    axes[1].set_title(f"zoom (grey span above), line-of-sight dynamics $f_{{d0}}$ = {float(res.attrs['fd0_hz']):g} Hz, "
                      f"$f_r$ = {float(res.attrs['fr_hz_s']):g} Hz/s removed", fontsize=8)
    axes[2].set_ylabel(f"estimate $-$ truth ({TRUTH_SMOOTH_S:g}-s mean) [Hz]", fontsize=8)
    axes[2].axvline(ss, color="0.4", lw=0.8, ls=":")
    bound = 1.3 * float(np.nanmax(np.abs(np.concatenate(diffs))))
    axes[2].set_ylim(-bound, bound)
    for ax in axes:
        ax.set_xlabel("time [s]")
        ax.legend(loc="best", fontsize=6.5, ncol=1 if ax is axes[2] else 2)
    fig.suptitle(f"Fig. {fig_no}: carrier Doppler estimates, {_where(res)} scenario, trial {int(res['example_trial'])}\n"
                 f"{_block_ms(res)}-ms means; truth = dynamics + clock + scintillation; {_cond(res)}\n{source_text(res)}", fontsize=9)
    fig.tight_layout()
    return fig


@figure("susi_fig07", "fig07_doppler_equatorial", paper=PAPER, section=SECTION, inputs=_result_inputs(EQUATORIAL), surrogate=_surrogate(EQUATORIAL))
def susi_fig07(result):
    return doppler_figure(result, 7)


# --- SAKF monitor ------------------------------------------------------------------------------


def _monitor_inputs(config):
    out = {}
    for sc in experiment_scenarios(config, CHAPTER):
        out[f"result_{sc}"] = paths.exp_result(CHAPTER, sc)
        out[f"indices_{sc}"] = paths.susi_indices_path(sc)
    return out


def _monitor_surrogate(config) -> bool:
    return any(scenario_is_surrogate(config, sc) for sc in experiment_scenarios(config, CHAPTER))


def _monitored(res: xr.Dataset) -> list[str]:
    return [str(tr) for tr in res["tracker"].values if "phi3_mean" in res and np.isfinite(res["phi3_mean"].sel(tracker=tr).values).any()]


@figure("susi_sakf_monitor", "sakf_monitor", paper=PAPER, section=SECTION, inputs=_monitor_inputs, surrogate=_monitor_surrogate)
def susi_sakf_monitor(*datasets):
    """Rows: Phi3, p, T, weight; columns: the scenarios (result and indices pairs in input order)."""
    results = [d for d in datasets if "tracker" in d.dims]
    indices = {d.attrs["scenario"]: d for d in datasets if "tracker" not in d.dims}
    rows = (("phi3", r"$\Phi_3$ [rad]"), ("p", "slope $p$"), ("T", "strength $T$ [rad$^2$/Hz]"), ("weight", "gain weight $w$"))
    fig, axes = new_figure(len(rows), len(results), figsize=(4.2 * len(results) + 0.8, 8.4), sharex="col", squeeze=False)
    for j, res in enumerate(results):
        ind = indices.get(res.attrs["scenario"])
        t = res["time"].values
        truth = {} if ind is None else {"phi3": (ind["grid"].values, ind["phi3_true"].values), "p": (ind["tp_time"].values, ind["p_true"].values),
                                         "T": (ind["tp_time"].values, ind["T_true"].values)}
        for i, (key, name) in enumerate(rows):
            ax = axes[i, j]
            if key in truth:
                ax.plot(*truth[key], lw=0.9, color="0.3", label=f"noise-free trace ({float(ind.attrs['phi3_window_s']):g}-s window, "
                        f"{float(ind.attrs.get('detrend_hz', np.nan)):g}-Hz high-pass)")
            stat = "mean over trials"
            if key == "T":  # a sharded result carries the first shard's median (experiments/merge.py)
                covered = int(res["T_mean"].attrs.get("median_trials", res["n_trials"]))
                stat = "median over trials" if covered == int(res["n_trials"]) else f"median over the first {covered} of {int(res['n_trials'])} trials"
            for k, tr in enumerate(_monitored(res)):
                ax.plot(t, res[f"{key}_mean"].sel(tracker=tr).values, lw=0.7, color=_colour(tr, 2 + k), label=f"{_label(res, tr)} on-line, own carrier phase ({stat})")
            if key == "T":
                ax.text(0.01, 0.97, f"on-line T: {stat}", transform=ax.transAxes, fontsize=6.5, va="top",
                        bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "none", "pad": 1.5})  # the legend (top row) shows the mean
                ax.set_yscale("log")
            if key == "weight":
                ax.set_ylim(bottom=0)
            if j == 0:
                ax.set_ylabel(name)
            if i == 0:
                ax.set_title(f"{_where(res)}: {_cond(res)}\n{int(res['n_trials'])} trials ({source_text(res).split(',')[0]})", fontsize=8)
        axes[0, j].legend(loc="best", fontsize=6.5)
        axes[-1, j].set_xlabel("time [s]")
    fig.suptitle("SAKF PLL: on-line scintillation parameters (eqs. 7, 8) and the eq. (12) gain weight $w = \\alpha(1 + \\Phi_3/\\phi_{ref})^{-\\gamma}$",
                 fontsize=9)
    fig.tight_layout()
    return fig
