"""Figures of Zhao, Khanafseh & Pervan for the receiver on our jammed dataset: Figs. 4, 6, 7, 9, 10, 11 and the ablation.

All read ``results/zhao_jamming/receiver.nc``
(:mod:`scintrack.experiments.gps_positioning`).  Time series are one Monte
Carlo trial (``zhao_receiver.figure_trial``) of the first satellite, as the
paper shows one run; the ablation figure shows every trial's statistics
with 95% intervals.  Every title says the data are synthetic.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ...experiments.metrics import mean_ci
from ...pipeline import paths
from ..registry import figure
from ..tables.zhao_jamming import sweep_summary
from .common import new_figure

if TYPE_CHECKING:
    import xarray as xr

PAPER = "zhao_jamming"
SEC_RX = "Zhao et al.: receiver through jamming"
SYNTHETIC = "synthetic SKYDEL-like data"
LABELS = {"pll": "Costas PLL (1 ms)", "mm_none": "MM KF, no bit prediction", "mm_mask": "MM KF, upload-robust mask", "mm_iode": "MM KF, IODE check"}
_RX = {"receiver": paths.ZHAO_RECEIVER}


def _onset(ax, res: xr.Dataset) -> None:
    ax.axvline(float(res.attrs["jammer_onset_s"]), color="0.4", lw=0.8, ls=":")


def _example(res: xr.Dataset, tracker: str, what: str, prn_index: int = 0):
    t = res["time_bit"].values
    return t, res[f"example_{what}"].sel(tracker=tracker).isel(prn=prn_index).values


def _pll_figure(res: xr.Dataset, t_max: float | None, fig_no: int, title: str):
    fig, (ax1, ax2) = new_figure(2, 1, figsize=(6.4, 5.6))
    t, e = _example(res, "pll", "phase")
    _, f = _example(res, "pll", "frequency")
    keep = t <= t_max if t_max is not None else np.ones_like(t, dtype=bool)
    ax1.plot(t[keep], np.degrees(e[keep]), lw=0.5)
    ax1.set_ylabel("phase error [deg] (mod 180)")
    ax1.set_ylim(-95, 95)
    ax2.plot(t[keep], f[keep], lw=0.5, color="tab:orange")
    ax2.set_ylabel("frequency error [Hz]")
    ax2.set_xlabel("time [s]")
    for ax in (ax1, ax2):
        if t_max is None:
            _onset(ax, res)
    prn = int(res["prn"].values[0])
    fig.suptitle(f"Fig. {fig_no}: {title}\nPRN {prn}, trial {int(res.attrs['figure_trial'])}, 3rd-order Costas PLL ({SYNTHETIC})")
    fig.tight_layout()
    return fig


@figure("zhao_fig06", "fig06_pll_clean", paper=PAPER, section=SEC_RX, inputs=lambda c: _RX)
def zhao_fig06(receiver):
    return _pll_figure(receiver, float(receiver.attrs["jammer_onset_s"]), 6, "PLL output, clean signal")


@figure("zhao_fig09", "fig09_pll_jammed", paper=PAPER, section=SEC_RX, inputs=lambda c: _RX)
def zhao_fig09(receiver):
    return _pll_figure(receiver, None, 9, f"PLL output under jamming (onset {float(receiver.attrs['jammer_onset_s']):g} s)")


@figure("zhao_fig10", "fig10_mm_jammed", paper=PAPER, section=SEC_RX, inputs=lambda c: _RX)
def zhao_fig10(receiver):
    fig, (ax1, ax2) = new_figure(2, 1, figsize=(6.4, 5.6))
    for name in [n for n in receiver["tracker"].values if n != "pll"]:
        t, e = _example(receiver, name, "phase")
        _, f = _example(receiver, name, "frequency")
        ax1.plot(t, np.degrees(e), lw=0.5, label=LABELS.get(name, name))
        ax2.plot(t, f, lw=0.5, label=LABELS.get(name, name))
    ax1.set_ylabel("clock phase error [deg]")
    ax1.set_ylim(-185, 185)
    ax2.set_ylabel("frequency error [Hz]")
    ax2.set_xlabel("time [s]")
    ax1.legend(fontsize=7, loc="lower left")
    for ax in (ax1, ax2):
        _onset(ax, receiver)
    prn = int(receiver["prn"].values[0])
    fig.suptitle(f"Fig. 10: MM Kalman filter under jamming ({float(receiver.attrs['cn0_jammed_dbhz']):.1f} dB-Hz)\n"
                 f"PRN {prn}, trial {int(receiver.attrs['figure_trial'])} ({SYNTHETIC})")
    fig.tight_layout()
    return fig


def _position_figure(res: xr.Dataset, tracker: str, t_max: float | None, fig_no: int, title: str):
    fig, axes = new_figure(3, 1, figsize=(6.4, 6.4), sharex=True)
    trial = int(res.attrs["figure_trial"])
    enu = res["enu_error"].sel(tracker=tracker).isel(trial=trial).values
    t = res["time"].values
    keep = t <= t_max if t_max is not None else np.ones_like(t, dtype=bool)
    for ax, j, name in zip(axes, range(3), ("east", "north", "up")):
        ax.plot(t[keep], enu[keep, j], lw=0.8)
        ax.set_ylabel(f"{name} error [m]")
        if t_max is None:
            _onset(ax, res)
            span = t >= float(res.attrs["jammer_onset_s"])
            which = "jammed part"
        else:
            span = keep
            which = "clean part"
        m, s = np.mean(enu[span, j]), np.std(enu[span, j], ddof=1)
        ax.set_title(f"{which}: mean {m:.1f} m, std {s:.1f} m", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(f"Fig. {fig_no}: {title}, {LABELS.get(tracker, tracker)} carrier aiding\ntrial {trial}, 1 Hz least squares, 4 satellites ({SYNTHETIC})")
    fig.tight_layout()
    return fig


@figure("zhao_fig07", "fig07_position_clean", paper=PAPER, section=SEC_RX, inputs=lambda c: _RX)
def zhao_fig07(receiver):
    return _position_figure(receiver, "pll", float(receiver.attrs["jammer_onset_s"]), 7, "position errors, clean signal")


@figure("zhao_fig11", "fig11_position_jammed", paper=PAPER, section=SEC_RX, inputs=lambda c: _RX)
def zhao_fig11(receiver):
    best = "mm_iode" if "mm_iode" in receiver["tracker"].values else str(receiver["tracker"].values[-1])
    return _position_figure(receiver, best, None, 11, "position errors through jamming")


@figure("zhao_fig04", "fig04_bit_prediction_map", paper=PAPER, section=SEC_RX, inputs=lambda c: _RX)
def zhao_fig04(receiver):
    from matplotlib.colors import ListedColormap

    fig, (ax1, ax2) = new_figure(1, 2, figsize=(8.0, 6.4))
    last = receiver["prediction_last"].values
    nxt = receiver["prediction_next"].values
    cmap = ListedColormap(["black", "0.75", "white"])
    for ax, data, title in ((ax1, last, "last 5 subframes (decoded)"), (ax2, nxt, "next 5 subframes: predictable bits")):
        ax.imshow(data, cmap=cmap, vmin=-1, vmax=1, aspect="auto", interpolation="nearest")
        for sf in range(1, 5):
            ax.axhline(10 * sf - 0.5, color="tab:red", lw=0.8)
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("bit in word")
        ax.set_yticks([4.5 + 10 * k for k in range(5)])
        ax.set_yticklabels([f"SF{k + 1}" for k in range(5)])
    frac = float(np.mean(nxt != 0))
    fig.suptitle(f"Fig. 4: bit prediction map, PRN {int(receiver.attrs['prediction_map_prn'])}, upload-robust mask "
                 f"({100 * frac:.0f}% of the next frame predictable)\nblack = level -1 (bit 1), white = +1, grey = not predicted ({SYNTHETIC})", fontsize=9)
    fig.tight_layout()
    return fig


@figure("zhao_ablation", "ablation", paper=PAPER, section=SEC_RX, inputs=lambda c: _RX)
def zhao_ablation(receiver):
    metrics = [("sv_phase_rmse_jammed", "phase RMSE jammed [rad]"), ("sv_in_lock_jammed", "time in lock (jammed)"),
               ("sv_bit_error_jammed", "wrong bit decisions (jammed)"), ("err3d_rms_jammed", "3D position RMS jammed [m]")]
    fig, axes = new_figure(2, 2, figsize=(8.0, 6.4))
    trackers = list(receiver["tracker"].values)
    x = np.arange(len(trackers))
    upload_prns = [int(p.split()[1]) for p in str(receiver.attrs["uploads"]).split(", ") if p.startswith("PRN")]
    for ax, (key, label) in zip(axes.ravel(), metrics):
        v = receiver[key].values
        if "prn" in receiver[key].dims:
            groups = [("no upload", [i for i, p in enumerate(receiver["prn"].values) if p not in upload_prns]),
                      ("upload during jamming", [i for i, p in enumerate(receiver["prn"].values) if p in upload_prns])]
            for j, (name, idx) in enumerate(groups):
                if not idx:
                    continue
                m, lo, hi = mean_ci(v[:, idx, :].reshape(len(trackers), -1), axis=1)
                ax.errorbar(x + 0.15 * (2 * j - 1), m, yerr=[m - lo, hi - m], fmt="o", ms=4, capsize=3, label=name)
        else:
            m, lo, hi = mean_ci(v, axis=1)
            ax.errorbar(x, m, yerr=[m - lo, hi - m], fmt="o", ms=4, capsize=3, color="k", label="all satellites")
        if key.startswith("err3d"):
            ax.set_yscale("log")
        ax.set_xticks(x)
        ax.set_xticklabels([LABELS.get(t, t).replace(", ", ",\n") for t in trackers], fontsize=6.5)
        ax.set_title(label, fontsize=9)
        ax.legend(fontsize=7)
    fig.suptitle(f"Ablation: {int(receiver.attrs['n_trials'])} trials of the 4-minute scenario, 95% intervals; "
                 f"jammed at {float(receiver.attrs['cn0_jammed_dbhz']):.1f} dB-Hz\nuploads: {receiver.attrs['uploads']} ({SYNTHETIC})", fontsize=9)
    fig.tight_layout()
    return fig


def _sweep_inputs(config) -> dict[str, str]:
    return {f"cn0_{i}": paths.zhao_sweep_point(c) for i, c in enumerate(config["zhao_receiver"]["cn0_sweep"]["cn0_dbhz"])}


@figure("zhao_sweep", "cn0_sweep", paper=PAPER, section=SEC_RX, inputs=_sweep_inputs)
def zhao_sweep(*points):
    s = sweep_summary(points)
    fig, axes = new_figure(1, 3, figsize=(10.0, 3.8))
    for ax, (key, label) in zip(axes, (("phase_rmse_jammed", "phase RMSE jammed [rad]"), ("in_lock_jammed", "time in lock (jammed)"),
                                        ("bit_error_jammed", "wrong bit decisions (jammed)"))):
        for j, tr in enumerate(s["trackers"]):
            m, lo, hi = s[key]["mean"][j], s[key]["lo"][j], s[key]["hi"][j]
            ax.errorbar(s["cn0"], m, yerr=[m - lo, hi - m], marker="o", ms=3, capsize=2, lw=1, label=LABELS.get(tr, tr))
        ax.set_xlabel("jammed C/N$_0$ [dB-Hz]")
        ax.set_title(label, fontsize=9)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"Where each receiver variant breaks: jammed C/N0 sweep, {int(points[0].attrs['n_trials'])} trials x "
                 f"{points[0].sizes['prn']} satellites, 95% intervals ({SYNTHETIC})", fontsize=9)
    fig.tight_layout()
    return fig
