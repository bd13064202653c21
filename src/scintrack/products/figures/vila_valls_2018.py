"""Figures of Vila-Valls et al. 2018 (TAES 54(4)), one function per figure.

Each function takes result Datasets (never raw data) and returns a
matplotlib Figure; the workflow script saves it.  The decorator on each
function registers it with the workflow (:mod:`scintrack.products`): its
rule name, output stem and inputs.  Titles take their numbers (C/N0, Ts,
trials) from the results' attributes, tracker names from the results'
``tracker_labels``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ...labels import tracker_label
from ...pipeline import paths
from ..registry import figure
from .common import new_figure, symlog_axis

if TYPE_CHECKING:
    import xarray as xr

PAPER = "vila_valls_2018"
SEC_AR = "Sec. III: AR models"
SEC_CSM = "Sec. VI: tracking on CSM data"
PSD_UNITS = {"amplitude": "dB (1/Hz)", "phase": "dB (rad$^2$/Hz)"}


def _case_title(diag: xr.Dataset, case: str) -> str:
    s4 = float(diag["s4"].sel(case=case))
    tau0 = float(diag["tau0"].sel(case=case))
    return f"{case.capitalize()}: $S_4$ = {s4:g}, $\\tau_0$ = {tau0:g} s"


def ar_psd_figure(diag: xr.Dataset, component: str, fig_no: int):
    """Figs. 1 and 3: empirical PSD of CSM amplitude/phase with AR(1..4) PSDs."""
    cases = list(diag["case"].values)
    fig, axes = new_figure(len(cases), 1, figsize=(6.4, 3.0 * len(cases)))
    axes = np.atleast_1d(axes)
    for ax, case in zip(axes, cases):
        d = diag.sel(case=case, component=component)
        f = d["freq"].values[1:]
        ax.semilogx(f, 10 * np.log10(d["psd_empirical"].values[1:]), color="0.2", lw=1.4, label="CSM (Welch)")
        for order in d["order"].values:
            ax.semilogx(f, 10 * np.log10(d["psd_ar"].sel(order=order).values[1:]), lw=1.0, ls="--", label=f"AR({order})")
        ax.set_title(_case_title(diag, case))
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel(f"PSD [{PSD_UNITS[component]}]")
        ax.legend(loc="lower left", ncol=3)
    fig.suptitle(f"Fig. {fig_no}: PSD of the scintillation {component} and of fitted AR models\n(synthetic CSM data, $T_s$ = {_ts_ms(diag)} ms)")
    fig.tight_layout()
    return fig


def pacf_figure(diag: xr.Dataset, component: str, fig_no: int, lags_shown: int):
    """Figs. 2 and 4: sample PACF with the 95% confidence band."""
    cases = list(diag["case"].values)
    fig, axes = new_figure(len(cases), 1, figsize=(6.4, 2.8 * len(cases)))
    axes = np.atleast_1d(axes)
    for ax, case in zip(axes, cases):
        d = diag.sel(case=case, component=component)
        lags = d["pacf_lag"].values[1 : lags_shown + 1]
        vals = d["pacf"].values[1 : lags_shown + 1]
        bound = d["pacf_bound"].values[1 : lags_shown + 1]
        outside = np.abs(vals) > bound
        ax.vlines(lags, 0, vals, color="tab:blue", lw=1.5)
        ax.plot(lags[outside], vals[outside], "o", color="tab:blue", ms=5, label="sample PACF (outside band)")
        ax.plot(lags[~outside], vals[~outside], "o", mfc="white", color="tab:blue", ms=5, label="sample PACF (inside band)")
        ax.plot(lags, bound, "--", color="tab:red", lw=1.0, label=f"95% band $\\pm${bound.mean():.3f}")
        ax.plot(lags, -bound, "--", color="tab:red", lw=1.0)
        ax.axhline(0, color="k", lw=0.6)
        ax.set_xticks(lags)
        ax.set_ylim(-1.05, 1.05)
        ax.set_title(_case_title(diag, case))
        ax.set_xlabel("lag")
        ax.set_ylabel("partial autocorrelation")
        ax.legend(loc="upper right")
    fig.suptitle(f"Fig. {fig_no}: sample PACF of the scintillation {component}\n(synthetic CSM data, $T_s$ = {_ts_ms(diag)} ms)")
    fig.tight_layout()
    return fig


def _ts_ms(ds: xr.Dataset) -> str:
    return f"{float(ds.attrs['ts']) * 1000:g}"


def _diag(config):
    return {"diag": paths.VV_DIAGNOSTICS}


def _pacf_lags(config):
    return {"lags_shown": config["figures"]["vila_valls_2018"]["pacf_lags_shown"]}


@figure("fig01", "fig01_csm_amplitude_psd_ar", paper=PAPER, section=SEC_AR, inputs=_diag)
def fig01(diag):
    return ar_psd_figure(diag, "amplitude", 1)


@figure("fig02", "fig02_csm_amplitude_pacf", paper=PAPER, section=SEC_AR, inputs=_diag, kwargs=_pacf_lags)
def fig02(diag, lags_shown):
    return pacf_figure(diag, "amplitude", 2, lags_shown)


@figure("fig03", "fig03_csm_phase_psd_ar", paper=PAPER, section=SEC_AR, inputs=_diag)
def fig03(diag):
    return ar_psd_figure(diag, "phase", 3)


@figure("fig04", "fig04_csm_phase_pacf", paper=PAPER, section=SEC_AR, inputs=_diag, kwargs=_pacf_lags)
def fig04(diag, lags_shown):
    return pacf_figure(diag, "phase", 4, lags_shown)


# --- Sections VI-A..D, F: tracking on CSM data ------------------------------

LOSS_OF_LOCK_RAD = 0.52  # 3 sigma = 90 deg rule of thumb quoted in Sec. VI-B


def _conditions(res: xr.Dataset) -> str:
    """C/N0 of the run, from the result's attributes."""
    return f"C/N$_0$ = {float(res.attrs['cn0_dbhz']):g} dB-Hz"


def _scenario_title(res: xr.Dataset) -> str:
    s4 = res["s4_true"].values
    tau0 = res["tau0_true"].values
    if np.all(s4 == 0):
        return "no scintillation"
    change = np.flatnonzero(np.diff(s4)) + 1
    parts = [f"$S_4$ = {s4[0]:g}, $\\tau_0$ = {tau0[0]:g} s"]
    for k in change:
        parts.append(f"$S_4$ = {s4[k]:g}, $\\tau_0$ = {tau0[k]:g} s from {res['time'].values[k]:g} s")
    return " $\\to$ ".join(parts)


SMOOTH_S = 0.5  # display only: mean squares averaged over 0.5 s before the root


def _smooth(rmse: np.ndarray, n: int) -> np.ndarray:
    from scipy.ndimage import uniform_filter1d

    return np.sqrt(uniform_filter1d(rmse**2, size=max(n, 1), mode="nearest"))


def rmse_panel(ax, res: xr.Dataset, trackers=None, kind: str = "wrapped", styles=None):
    """RMSE of theta_d against time with its 95% band, log scale (0.5 s display smoothing)."""
    t = res["time"].values
    n = int(round(SMOOTH_S / (t[1] - t[0])))
    for name in trackers or list(res["tracker"].values):
        d = res.sel(tracker=name, kind=kind)
        style = {"lw": 1.1, **(styles or {}).get(name, {})}
        (line,) = ax.semilogy(t, _smooth(d["rmse"].values, n), label=tracker_label(res, name, for_figure=True), **style)
        ax.fill_between(t, _smooth(d["rmse_lo"].values, n), _smooth(d["rmse_hi"].values, n), color=line.get_color(), alpha=0.2, lw=0)
    ax.axhline(LOSS_OF_LOCK_RAD, color="k", ls=":", lw=0.8, label="0.52 rad (loss of lock)")
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"RMSE of $\\theta_d$ [rad] ({kind}, 0.5 s mean)")
    ax.set_title(_scenario_title(res), fontsize=9)
    ax.legend(loc="upper right", ncol=2, fontsize=7)


def _two_panels(top, bottom, fig_no, caption, **kw):
    fig, axes = new_figure(2, 1, figsize=(6.4, 6.6))
    rmse_panel(axes[0], top, **kw)
    rmse_panel(axes[1], bottom, **kw)
    fig.suptitle(f"Fig. {fig_no}: {caption}\n(synthetic CSM data, {_conditions(top)}, {int(top['n_trials'])} trials, 95% bands)")
    fig.tight_layout()
    return fig


@figure("fig06", "fig06_rmse_free_and_ssm_equivalence", paper=PAPER, section=SEC_CSM,
        inputs=lambda c: {"free": paths.exp_result("case1_free", "free"), "equivalence": paths.exp_result("case1_equivalence", "s4_0.8_tau0_0.2")})
def fig06(free, equivalence):
    styles = {"aekf_ar13": {"ls": "-"}, "aekf_ar23": {"ls": "--"}, "aekf_ar33": {"ls": ":", "lw": 2}}
    return _two_panels(free, equivalence, 6, "RMSE without scintillation (top) and SSM #2-#4 equivalence (bottom)", styles=styles)


@figure("fig07", "fig07_rmse_severe_moderate", paper=PAPER, section=SEC_CSM,
        inputs=lambda c: {"severe": paths.exp_result("case2_steady_state", "s4_0.9_tau0_0.1"), "moderate": paths.exp_result("case2_steady_state", "s4_0.5_tau0_0.4")})
def fig07(severe, moderate):
    return _two_panels(severe, moderate, 7, "RMSE, extreme (top) and moderate (bottom) scintillation")


@figure("fig08", "fig08_rmse_ar_mismatch", paper=PAPER, section=SEC_CSM, inputs=lambda c: {"mismatch": paths.exp_result("case3_mismatch", "s4_0.8_tau0_0.2")})
def fig08(mismatch):
    fig, ax = new_figure(1, 1, figsize=(6.4, 3.6))
    rmse_panel(ax, mismatch, trackers=[t for t in mismatch["tracker"].values if t != "aekf_pred_0.5" and t != "aekf_pred_0.4"])
    fig.suptitle(f"Fig. 8: AEKF-AR with AR-model mismatch\n(synthetic CSM data, {_conditions(mismatch)}, {int(mismatch['n_trials'])} trials, 95% bands)")
    fig.tight_layout()
    return fig


@figure("fig09", "fig09_rmse_time_varying", paper=PAPER, section=SEC_CSM,
        inputs=lambda c: {"severe_to_moderate": paths.exp_result("case4_transitions", "severe_to_moderate"), "moderate_to_severe": paths.exp_result("case4_transitions", "moderate_to_severe")})
def fig09(severe_to_moderate, moderate_to_severe):
    fig = _two_panels(severe_to_moderate, moderate_to_severe, 9, "time-varying scintillation")
    for ax, res in zip(fig.axes, (severe_to_moderate, moderate_to_severe)):
        s4 = res["s4_true"].values
        for k in np.flatnonzero(np.diff(s4)) + 1:
            ax.axvline(res["time"].values[k], color="0.4", lw=0.8, ls="--")
    return fig


@figure("fig16", "fig16_cycle_slip_examples", paper=PAPER, section=SEC_CSM,
        inputs=lambda c: {f"case{k}": paths.exp_result("cycle_slips", f"slips_case{k}") for k in (1, 2, 3)})
def fig16(case1, case2, case3):
    fig, axes = new_figure(3, 1, figsize=(6.4, 8.0))
    for ax, res in zip(axes, (case1, case2, case3)):
        t = res["time"].values
        for name in res["tracker"].values:
            ax.plot(t, res["example_error"].sel(tracker=name).values / (2 * np.pi), lw=0.8, label=tracker_label(res, name, for_figure=True))
        ax.set_xlabel("time [s]")
        if np.abs(res["example_error"].values).max() > 2 * 2 * np.pi:
            symlog_axis(ax, linthresh=2.0)
            ax.set_ylabel("phase error [cycles] (symlog)")
        else:
            ax.set_ylabel("phase error [cycles]")
        ax.set_title(f"{_scenario_title(res)}, trial {int(res['example_trial'])}")
        ax.legend(loc="upper left", ncol=3, fontsize=7)
    fig.suptitle(f"Fig. 16: phase error of one realisation (unwrapped, in cycles)\n(synthetic CSM data, {_conditions(case1)})")
    fig.tight_layout()
    return fig
