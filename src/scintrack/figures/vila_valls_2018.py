"""Figures of Vila-Valls et al. 2018 (TAES 54(4)), one function per figure.

Each function takes result Datasets (never raw data) and returns a
matplotlib Figure; the workflow script saves it.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .common import new_figure

COMPONENT_LABEL = {"amplitude": "amplitude", "phase": "phase"}
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
    fig.suptitle(f"Fig. {fig_no}: PSD of the scintillation {COMPONENT_LABEL[component]} and of fitted AR models\n(synthetic CSM data, $T_s$ = 10 ms)")
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
    fig.suptitle(f"Fig. {fig_no}: sample PACF of the scintillation {COMPONENT_LABEL[component]}\n(synthetic CSM data, $T_s$ = 10 ms)")
    fig.tight_layout()
    return fig


def fig01(diag):
    return ar_psd_figure(diag, "amplitude", 1)


def fig02(diag, lags_shown):
    return pacf_figure(diag, "amplitude", 2, lags_shown)


def fig03(diag):
    return ar_psd_figure(diag, "phase", 3)


def fig04(diag, lags_shown):
    return pacf_figure(diag, "phase", 4, lags_shown)
