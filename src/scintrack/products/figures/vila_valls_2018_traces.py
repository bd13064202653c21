"""Figures 10-15 of Vila-Valls et al. 2018 (Sec. VI-E, multi-frequency traces).

Each function takes the result Datasets of its rule and returns a figure.
The data source (``attrs["source"]``: "real" or "surrogate") is printed in
every title; surrogate figures say plainly that they are not JRC data.
Registered with the workflow by the decorators (:mod:`scintrack.products`);
their files get the ``_surrogate`` suffix when the traces are the surrogate.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ...labels import tracker_label
from ...pipeline import paths
from ..registry import figure
from .common import new_figure, symlog_axis
from .vila_valls_2018 import LOSS_OF_LOCK_RAD

if TYPE_CHECKING:
    import xarray as xr

PAPER = "vila_valls_2018"
SEC_TRACES = "Sec. VI-E: real traces"


def _rt(config):
    return config["real_traces"]


def _diag(config):
    return {"diag": paths.trace_diagnostics_path(config)}

BAND_COLOURS = {"L1": "C0", "L2": "C1", "L5": "C2"}


def source_note(ds: xr.Dataset) -> str:
    if ds.attrs.get("source") == "real":
        return "real JRC Hanoi traces"
    return "SYNTHETIC SURROGATE (phase screen), not JRC data"


@figure("fig10", "fig10_trace_amplitude_bands", paper=PAPER, section=SEC_TRACES, trace=True,
        inputs=lambda c: {"trace": paths.trace_path(c, _rt(c)["fig10"]["event"])},
        kwargs=lambda c: {"start_s": _rt(c)["fig10"]["start_s"], "length_s": _rt(c)["fig10"]["length_s"]})
def fig10(trace, start_s: float = 0.0, length_s: float = 100.0):
    """100 s of amplitude at every band, in dB."""
    fig, axes = new_figure(trace.sizes["band"], 1, figsize=(6.4, 6.0), sharex=True)
    t = trace["time"].values
    sel = (t >= start_s) & (t < start_s + length_s)
    for ax, band in zip(np.atleast_1d(axes), trace["band"].values):
        rho = trace["amplitude"].sel(band=band).values[sel].astype(float)
        ax.plot(t[sel], 20 * np.log10(np.maximum(rho, 1e-4)), lw=0.6, color=BAND_COLOURS.get(str(band)))
        ax.set_ylabel(f"{band} amplitude [dB]")
        ax.set_ylim(-40, 10)
    np.atleast_1d(axes)[-1].set_xlabel("time [s]")
    fig.suptitle(f"Fig. 10: scintillation amplitude, {trace.attrs['event']}\n({source_note(trace)})")
    fig.tight_layout()
    return fig


@figure("fig11", "fig11_static_scintillation_tracking", paper=PAPER, section=SEC_TRACES, trace=True,
        inputs=lambda c: {"static": paths.trace_static_path(c, _rt(c)["fig11"]["event"])}, kwargs=lambda c: {"band": _rt(c)["fig11"]["band"]})
def fig11(static, band: str = "L1"):
    """True and AEKF-AR-estimated amplitude and phase (dynamics-free), first trial."""
    fig, axes = new_figure(2, 1, figsize=(6.4, 6.0), sharex=True)
    t = static["time"].values
    d = static.sel(band=band)
    axes[0].plot(t, d["example_rho_true"].values, lw=0.8, label="trace")
    axes[0].plot(t, d["example_rho_hat"].values, lw=0.8, ls="--", label="AEKF-AR estimate")
    axes[0].set_ylabel(r"amplitude $\rho_s$")
    axes[1].plot(t, d["example_theta_true"].values, lw=0.8, label="trace")
    axes[1].plot(t, d["example_theta_hat"].values, lw=0.8, ls="--", label="AEKF-AR estimate")
    axes[1].set_ylabel(r"phase $\theta_s$ [rad]")
    axes[1].set_xlabel("time after the fitting segment [s]")
    for ax in axes:
        ax.legend(loc="upper right")
    fig.suptitle(
        f"Fig. 11: dynamics-free tracking, {static.attrs['event']} {band}, C/N$_0$ = {static.attrs['cn0_dbhz']:g} dB-Hz\n"
        f"({source_note(static)})"
    )
    fig.tight_layout()
    return fig


@figure("fig12", "fig12_trace_s4", paper=PAPER, section=SEC_TRACES, trace=True, inputs=_diag)
def fig12(diag):
    """S4 against time of every event (all bands)."""
    events = list(diag["event"].values)
    fig, axes = new_figure(len(events), 1, figsize=(6.4, 6.6), sharex=True)
    t = diag["s4_time"].values
    for ax, ev in zip(np.atleast_1d(axes), events):
        for band in diag["band"].values:
            ax.plot(t, diag["s4"].sel(event=ev, band=band).values, lw=1.0, color=BAND_COLOURS.get(str(band)), label=str(band))
        ax.set_ylabel(f"{ev}: S$_4$")
        ax.set_ylim(0, 1.6)
        ax.legend(loc="upper left", ncol=3)
    np.atleast_1d(axes)[-1].set_xlabel("time [s] (window centre)")
    window = diag["s4"].attrs.get("long_name", "")
    fig.suptitle(f"Fig. 12: S$_4$ index of the three events ({window})\n({source_note(diag)})")
    fig.tight_layout()
    return fig


def _pacf(diag, component: str, fig_no: int):
    fig, axes = new_figure(3, 1, figsize=(6.4, 7.0))
    for ax, seg in zip(axes, diag["segment"].values):
        v = diag["pacf"].sel(segment=seg, component=component).values
        b = diag["pacf_bound"].sel(segment=seg, component=component).values
        lags = diag["lag"].values
        ax.bar(lags[1:], v[1:], width=0.4, color="C0")
        ax.plot(lags[1:], b[1:], "r--", lw=0.8)
        ax.plot(lags[1:], -b[1:], "r--", lw=0.8, label="95% band")
        ax.axhline(0, color="k", lw=0.5)
        ax.set_ylabel("PACF")
        ax.set_title(
            f"{seg}: {diag['segment_event'].sel(segment=seg).item()}, L1, {diag.attrs['segment_s']:g} s from "
            f"{float(diag['segment_start_s'].sel(segment=seg)):g} s, S$_4$ = {float(diag['segment_s4'].sel(segment=seg)):.2f}",
            fontsize=9,
        )
        ax.legend(loc="upper right")
    axes[-1].set_xlabel("lag")
    fig.suptitle(f"Fig. {fig_no}: sample PACF of the scintillation {component}\n({source_note(diag)})")
    fig.tight_layout()
    return fig


@figure("fig13", "fig13_trace_amplitude_pacf", paper=PAPER, section=SEC_TRACES, trace=True, inputs=_diag, kwargs=lambda c: {"component": "amplitude"})
def fig13(diag, component: str = "amplitude"):
    return _pacf(diag, component, 13)


@figure("fig14", "fig14_trace_phase_pacf", paper=PAPER, section=SEC_TRACES, trace=True, inputs=_diag, kwargs=lambda c: {"component": "phase"})
def fig14(diag, component: str = "phase"):
    return _pacf(diag, component, 14)


@figure("fig15", "fig15_trace_phase_error", paper=PAPER, section=SEC_TRACES, trace=True,
        inputs=lambda c: {f"{e}_{b}": paths.trace_dynamics_path(c, e) for e, b in _rt(c)["fig15"]},
        kwargs=lambda c: {"cases": [list(case) for case in _rt(c)["fig15"]]})
def fig15(*results, cases=()):
    """Dynamics phase error (unwrapped, in cycles, first realisation) of every tracker on two event/band cases.

    Unwrapped and in cycles, as in Fig. 16: a tracker that loses lock under
    100 Hz/s dynamics runs away, and a wrapped plot of that is unreadable.
    """
    fig, axes = new_figure(len(cases), 1, figsize=(6.4, 6.6))
    for ax, res, (event, band) in zip(np.atleast_1d(axes), results, cases):
        d = res.sel(band=band)
        t = d["time"].values
        for name in d["tracker"].values:
            ax.plot(t, d["example_error"].sel(tracker=name).values / (2 * np.pi), lw=0.8, label=tracker_label(res, name, for_figure=True))
        lock = LOSS_OF_LOCK_RAD / (2 * np.pi)
        ax.axhspan(-lock, lock, color="0.85", lw=0, label="$\\pm$0.52 rad")
        if np.abs(d["example_error"].values).max() > 4 * np.pi:
            symlog_axis(ax, linthresh=1.0)
            ax.set_ylabel(r"$\theta_d$ error [cycles] (symlog)")
        else:
            ax.set_ylabel(r"$\theta_d$ error [cycles]")
        ax.set_title(f"{event}, {band}, realisation {int(d['example_trial'])}", fontsize=9)
        ax.legend(loc="upper left", ncol=3, fontsize=7)
    np.atleast_1d(axes)[-1].set_xlabel("time after the fitting segment [s]")
    fig.suptitle(f"Fig. 15: dynamics phase error, traces + aeronautical dynamics\n({source_note(results[0])})")
    fig.tight_layout()
    return fig
