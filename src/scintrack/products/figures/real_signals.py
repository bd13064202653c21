"""Figures of the real GPS recordings: the acquisition search of each capture, and the tracking of the 0.5-s capture.

No paper has these figures; they show what the receiver's chain does on real
samples (docs/real-signals.md), drawn from the results of the
``real_acquisition`` and ``real_tracking`` rules.

* **Acquisition, one figure per capture**: (a) the normalised peak Lambda of
  every PRN searched against the detection threshold gamma, detections in
  colour with their C/N0, cross-correlations of a stronger satellite in
  orange; (b) the strongest satellite's largest statistic over the code
  phases of each Doppler bin, with gamma and, in grey, the largest over the
  PRNs that were not detected (how far noise stays below gamma); (c) the same
  statistic for every PRN and Doppler bin as a map, detections circled.
  Lambda is in units of the per-cell noise (Gamma(K, 1) without signal), so
  the axes are logarithmic.
* **Tracking of the 0.5-s Pocket SDR capture**: the four satellites with the
  highest mean C/N0 as rows: the PLL channel's prompt in the loop's phase
  frame (data bits on I, noise on Q) with the data transitions the bit
  synchronisation found; the Costas phase errors of the PLL and of the MM
  filter; the sliding M2M4 C/N0 beside the acquisition's estimate.  A
  summary panel below gives every tracked satellite's mean C/N0, lock
  fraction and bit-edge fraction.  The pull-in (open-loop refinement, PLL
  start, MM filter not yet running) is shaded and left out of the
  statistics.

Titles say "real recordings" (``conventions.data_title``); file names end in
``_real`` (:meth:`scintrack.products.registry.Product.suffix`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ...pipeline import paths
from ..registry import REAL_PAPER, Verdict, figure
from .common import new_figure
from .conventions import MIN_FONT_PT, data_title, figure_legend, handles_of, log_ticks

if TYPE_CHECKING:
    import xarray as xr

SECTION = "Real GPS L1 recordings"
REAL = data_title("real")
#: the captures with an acquisition figure: registry name -> (figure rule, file stem, front end as a reader names it)
CAPTURES = {
    "real_pocketsdr_l1_4mhz_iq": ("real_fig_acquisition_pocketsdr_iq", "acquisition_pocketsdr_4mhz_iq", "Pocket SDR (MAX2771, 2-bit)"),
    "real_pocketsdr_l1_12mhz_if": ("real_fig_acquisition_pocketsdr_if", "acquisition_pocketsdr_12mhz_if", "Pocket SDR (MAX2771, 2-bit)"),
    "real_gnss_sdr_gsoc_4ms": ("real_fig_acquisition_gnss_sdr", "acquisition_gnss_sdr_4ms", "GNSS-SDR test capture (USRP1 + DBSRX)"),
}
#: the capture whose tracking is drawn (the only one long enough for pull-in and bit synchronisation)
TRACKED_CAPTURE = "real_pocketsdr_l1_4mhz_iq"
#: rows of the tracking figure (satellites with the highest mean C/N0)
TRACKING_ROWS = 4
COLOURS = {"detected": "tab:blue", "cross": "tab:orange", "absent": "0.72", "threshold": "tab:red", "noise": "0.55",
           "pll": "tab:blue", "mm": "tab:red", "i": "tab:blue", "q": "tab:orange", "edge": "0.35", "pull_in": "0.85"}
#: a satellite counts as tracked well when locked this often after pull-in and its sign changes fall on one bit phase this often
GOOD_LOCK, GOOD_EDGES = 0.9, 0.9


def capture_label(acq: xr.Dataset, front_end: str) -> str:
    """``front end: rate, I/Q or real IF, length, date`` of a capture, from its acquisition result."""
    a = acq.attrs
    iq = "IQ" in str(a["format"]) or "complex" in str(a["format"])
    kind = "complex I/Q at baseband" if iq and float(a["intermediate_frequency_hz"]) == 0 else (
        "I/Q" if iq else f"real samples at IF {float(a['intermediate_frequency_hz']) / 1e6:g} MHz")
    return (f"{front_end}: {float(a['sample_rate_hz']) / 1e6:g} MS/s {kind}, {float(a['duration_s']) * 1e3:g} ms, "
            f"{str(a['start_time'])[:10]}")


def search_label(acq: xr.Dataset) -> str:
    a = acq.attrs
    blocks = int(a["n_blocks"])
    return (f"{int(a['n_coherent_ms'])} ms coherent x {blocks} block{'s' if blocks > 1 else ''}, "
            f"Doppler +-{float(a['doppler_span_hz']) / 1e3:g} kHz in {float(a['doppler_step_hz']):.3g}-Hz bins, "
            f"P_fa {float(a['p_fa']):g} per search")


def _status(acq: xr.Dataset) -> np.ndarray:
    """Per PRN: "detected", "cross" (explained by a stronger satellite's cross-correlation) or "absent"."""
    detected = acq["detected"].values.astype(bool)
    cross = acq["cross_correlation_of"].values > 0
    return np.where(detected, "detected", np.where(cross, "cross", "absent"))


def _strongest(acq: xr.Dataset) -> int:
    """Index of the PRN with the largest statistic among the detected ones (among all when none is)."""
    stat = acq["statistic"].values
    detected = acq["detected"].values.astype(bool)
    return int(np.argmax(np.where(detected, stat, -np.inf))) if detected.any() else int(np.argmax(stat))


def _bars_panel(ax, acq: xr.Dataset) -> None:
    prns = acq["prn"].values
    stat, status = acq["statistic"].values, _status(acq)
    gamma = float(acq["threshold"])
    x = np.arange(prns.size)
    names = {"detected": "detected (number: C/N$_0$ from the peak [dB-Hz])", "cross": "cross-correlation of a stronger satellite",
             "absent": "below the threshold"}
    for kind, label in names.items():
        sel = status == kind
        if sel.any():
            ax.bar(x[sel], stat[sel], width=0.7, color=COLOURS[kind], label=label)
    for i in np.flatnonzero(status == "detected"):
        ax.annotate(f"{acq['cn0_dbhz'].values[i]:.0f}", (x[i], stat[i]), xytext=(0, 1.5), textcoords="offset points",
                    ha="center", va="bottom", fontsize=MIN_FONT_PT)
    for i in np.flatnonzero(status == "cross"):
        ax.annotate(f"of {int(acq['cross_correlation_of'].values[i])}", (x[i], stat[i]), xytext=(0, 1.5), textcoords="offset points",
                    ha="center", va="bottom", fontsize=MIN_FONT_PT, color=COLOURS["cross"])
    ax.axhline(gamma, color=COLOURS["threshold"], ls="--", lw=1.0, label=f"threshold $\\gamma$ = {gamma:.1f}")
    ax.set_yscale("log")
    ax.set_ylim(max(0.5 * float(np.min(stat)), 1.0), 2.2 * float(np.max(stat)))
    log_ticks(ax)
    ax.set_xticks(x)
    ax.set_xticklabels([str(int(p)) for p in prns], fontsize=MIN_FONT_PT if prns.size > 16 else 8)
    ax.set_xlim(-0.6, prns.size - 0.4)
    ax.set_xlabel("PRN searched")
    ax.set_ylabel("peak $\\Lambda$ [noise units]")
    ax.grid(axis="x", visible=False)


def _profile_panel(ax, acq: xr.Dataset) -> None:
    k = _strongest(acq)
    f = acq["doppler"].values / 1e3
    per_bin = acq["bin_statistic"].values
    status = _status(acq)
    gamma = float(acq["threshold"])
    prn = int(acq["prn"].values[k])
    absent = status == "absent"
    if absent.any():
        ax.plot(f, per_bin[absent].max(axis=0), color=COLOURS["noise"], lw=0.8,
                label=f"largest over the {int(absent.sum())} PRNs below the threshold")
    ax.plot(f, per_bin[k], color="k", lw=1.0, marker="." if f.size < 80 else None, ms=3, label=f"PRN {prn} (strongest)")
    ax.axhline(gamma, color=COLOURS["threshold"], ls="--", lw=1.0)
    peak = float(acq["doppler_hz"].values[k]) / 1e3
    right = peak > 0.5 * (f[0] + f[-1])  # the label in the upper corner away from the peak
    ax.text(0.015 if right else 0.985, 0.95, f"PRN {prn}: peak at {peak * 1e3:+.0f} Hz, code phase {float(acq['code_phase_chips'].values[k]):.1f} chips",
            transform=ax.transAxes, fontsize=7.5, va="top", ha="left" if right else "right")
    ax.set_yscale("log")
    ax.set_ylim(max(0.5 * float(np.min(per_bin[k])), 1.0), 2.2 * float(np.max(per_bin)))
    log_ticks(ax)
    ax.set_xlim(f[0], f[-1])
    ax.set_xlabel("Doppler bin [kHz]")
    ax.set_ylabel("max over code phase [noise units]")


def _map_panel(fig, ax, acq: xr.Dataset) -> None:
    from matplotlib.colors import LogNorm

    f = acq["doppler"].values / 1e3
    prns = acq["prn"].values
    per_bin = acq["bin_statistic"].values
    step = (f[1] - f[0]) if f.size > 1 else 1.0
    edges_f = np.concatenate([f - step / 2, [f[-1] + step / 2]])
    edges_p = np.arange(prns.size + 1) - 0.5
    mesh = ax.pcolormesh(edges_f, edges_p, per_bin, norm=LogNorm(vmin=max(float(per_bin.min()), 1.0), vmax=float(per_bin.max())),
                         cmap="viridis", shading="flat", rasterized=True)
    detected = np.flatnonzero(acq["detected"].values.astype(bool))
    ax.plot(acq["doppler_hz"].values[detected] / 1e3, detected, ls="none", marker="o", ms=9, mfc="none", mec="w", mew=1.2)
    cross = np.flatnonzero(acq["cross_correlation_of"].values > 0)
    ax.plot(acq["doppler_hz"].values[cross] / 1e3, cross, ls="none", marker="o", ms=9, mfc="none", mec=COLOURS["cross"], mew=1.2)
    every = max(1, int(math.ceil(prns.size / 8)))
    ticks = sorted(set(range(0, prns.size, every)) | {prns.size - 1})
    ax.set_yticks(ticks)
    ax.set_yticklabels([str(int(prns[i])) for i in ticks])
    ax.set_ylabel("PRN")
    ax.set_xlabel("Doppler bin [kHz] (white circles: detections; orange: cross-correlations)")
    ax.grid(False)
    bar = fig.colorbar(mesh, ax=ax, pad=0.015, fraction=0.04)
    bar.set_label("max over code phase [noise units]", fontsize=8)
    bar.ax.tick_params(labelsize=MIN_FONT_PT)
    log_ticks(bar.ax)


def acquisition_figure(acquisition: xr.Dataset, front_end: str = ""):
    """Acquisition search of one real capture: every PRN's peak against the threshold, the strongest satellite per Doppler bin, the PRN x Doppler map."""
    fig, (ax1, ax2, ax3) = new_figure(3, 1, figsize=(6.8, 8.2), gridspec_kw={"height_ratios": [1.0, 1.0, 1.15]})
    _bars_panel(ax1, acquisition)
    ax1.set_title("(a) every PRN: normalised peak against the threshold", fontsize=8.5)
    _profile_panel(ax2, acquisition)
    ax2.set_title("(b) strongest satellite: largest statistic per Doppler bin", fontsize=8.5)
    _map_panel(fig, ax3, acquisition)
    ax3.set_title("(c) every PRN and Doppler bin", fontsize=8.5)
    fig.suptitle(f"Acquisition search of one of the {REAL}\n{capture_label(acquisition, front_end)}\n{search_label(acquisition)}", fontsize=8.5)
    fig.tight_layout()
    figure_legend(fig, *handles_of(ax1, ax2), ncol=2, fontsize=7.5)
    return fig


def verdict_acquisition(acquisition: xr.Dataset, front_end: str = "") -> Verdict:
    """No paper figure.  The line gives the satellites detected above gamma (with their C/N0 range), the peaks marked as
    cross-correlations, and the largest statistic of a PRN not detected against gamma (the noise margin)."""
    status = _status(acquisition)
    prns, stat, cn0 = acquisition["prn"].values, acquisition["statistic"].values, acquisition["cn0_dbhz"].values
    gamma = float(acquisition["threshold"])
    det = status == "detected"
    parts = [f"{int(det.sum())} of {prns.size} PRNs detected above gamma = {gamma:.1f} at P_fa {float(acquisition.attrs['p_fa']):g}"
             + (f" (PRN {', '.join(str(int(p)) for p in prns[det])}; C/N0 {np.min(cn0[det]):.1f}-{np.max(cn0[det]):.1f} dB-Hz)" if det.any() else "")]
    cross = status == "cross"
    if cross.any():
        parts.append("cross-correlations: " + ", ".join(f"PRN {int(p)} of {int(o)}" for p, o in
                                                        zip(prns[cross], acquisition["cross_correlation_of"].values[cross])))
    absent = status == "absent"
    if absent.any():
        parts.append(f"largest peak below the threshold {np.max(stat[absent]):.1f}")
    return Verdict("no paper figure", "; ".join(parts))


def _register_acquisition_figures() -> None:
    for name, (rule, stem, front_end) in CAPTURES.items():
        figure(rule, stem, paper=REAL_PAPER, section=SECTION,
               inputs=lambda c, name=name: {"acquisition": paths.real_acquisition_path(name)},
               kwargs=lambda c, front_end=front_end: {"front_end": front_end}, number=None,
               claim=f"No paper figure: the receiver's acquisition finds the GPS satellites of a real {front_end} capture, "
                     "with a threshold for a stated false-alarm probability",
               verdict=verdict_acquisition)(acquisition_figure)


_register_acquisition_figures()


# --- tracking of the 0.5-s capture


def _rows(tracking: xr.Dataset) -> list[int]:
    """Indices of the satellites drawn as rows: the highest mean C/N0 first."""
    order = np.argsort(-np.nan_to_num(tracking["mean_cn0_dbhz"].values, nan=-np.inf), kind="stable")
    return [int(i) for i in order[:TRACKING_ROWS]]


def _prompt_panel(ax, one: xr.Dataset, t: np.ndarray) -> None:
    i, q = one["prompt_i"].values, one["prompt_q"].values
    ax.plot(t, q, color=COLOURS["q"], lw=0.6, label="quadrature prompt (noise when locked)")
    ax.plot(t, i, color=COLOURS["i"], lw=0.7, label="in-phase prompt (the data bits)")
    edges = t[one["bit_edge"].values.astype(bool)]
    top = float(np.nanmax(np.abs(i))) * 1.15
    if edges.size:
        ax.vlines(edges, -top, top, color=COLOURS["edge"], lw=0.7, ls=":", label="data transition found by bit synchronisation")
    ax.set_ylim(-top, top)


def _phase_panel(ax, one: xr.Dataset, t: np.ndarray) -> None:
    ax.plot(t, one["pll_phase_error"].values, color=COLOURS["pll"], lw=0.6, label="Costas PLL phase error")
    ax.plot(t, one["mm_phase_error"].values, color=COLOURS["mm"], lw=0.6, alpha=0.75, label="MM filter phase error (starts after the pull-in)")
    ax.set_ylim(-math.pi / 2, math.pi / 2 + 0.8)  # the Costas range (-pi/2, pi/2] and a band above it for the numbers
    ax.set_yticks([-1.5, -0.75, 0, 0.75, 1.5])
    ax.text(0.99, 0.97, f"std after pull-in: PLL {float(one['pll_phase_error_std']):.2f}, MM {float(one['mm_phase_error_std']):.2f} rad",
            transform=ax.transAxes, ha="right", va="top", fontsize=MIN_FONT_PT)


def _cn0_panel(ax, one: xr.Dataset, t: np.ndarray, acq_cn0: float, window_ms: int) -> None:
    ax.plot(t, one["cn0"].values, color="k", lw=0.9, label=f"C/N$_0$, M2M4 over {window_ms} ms")
    if np.isfinite(acq_cn0):
        ax.axhline(acq_cn0, color="tab:green", ls="--", lw=0.9, label="C/N$_0$ from the acquisition peak")


def tracking_figure(tracking: xr.Dataset, acquisition: xr.Dataset):
    """Tracking of the 0.5-s Pocket SDR capture: prompts with the bit edges found, PLL and MM phase errors and C/N0 of the strongest satellites; a summary of all."""
    rows = _rows(tracking)
    n = len(rows)
    fig, axes = new_figure(n + 1, 3, figsize=(7.6, 1.75 * n + 2.9), gridspec_kw={"height_ratios": [1.0] * n + [1.25]})
    axes = np.atleast_2d(axes)
    pull_in = float(tracking.attrs["pull_in_ms"]) * 1e-3
    acq_cn0 = dict(zip(acquisition["prn"].values.tolist(), acquisition["cn0_dbhz"].values.tolist()))
    for r, k in enumerate(rows):
        one = tracking.isel(prn=k)
        prn = int(one["prn"])
        t = one["time"].values
        _prompt_panel(axes[r, 0], one, t)
        _phase_panel(axes[r, 1], one, t)
        _cn0_panel(axes[r, 2], one, t, acq_cn0.get(prn, math.nan), int(tracking.attrs["cn0_window_ms"]))
        axes[r, 0].set_ylabel(f"PRN {prn}\nprompt [ADC levels]", fontsize=8)
        axes[r, 1].set_ylabel("phase error [rad]", fontsize=8)
        axes[r, 2].set_ylabel("C/N$_0$ [dB-Hz]", fontsize=8)
        for ax in axes[r]:
            ax.axvspan(0.0, pull_in, color=COLOURS["pull_in"], lw=0, zorder=0, label=f"pull-in ({pull_in * 1e3:g} ms, not in the statistics)")
            ax.set_xlim(0.0, float(np.nanmax(t)))
            ax.tick_params(labelsize=MIN_FONT_PT)
            if r == n - 1:
                ax.set_xlabel("time from the first sample [s]", fontsize=8)
    for ax, title in zip(axes[0], ("prompt after the PLL's carrier wipe-off", "Costas phase error", "C/N$_0$, sliding M2M4")):
        ax.set_title(title, fontsize=8.5)
    grid = axes[0, 0].get_gridspec()
    for ax in axes[n]:
        ax.remove()
    summary = fig.add_subplot(grid[n, :])  # one panel across the bottom row
    _summary_panel(summary, tracking, rows)
    fig.suptitle(f"Tracking of one of the {REAL}: {capture_label(acquisition, CAPTURES[TRACKED_CAPTURE][2])}\n"
                 f"Costas PLL (B$_n$ = {float(tracking.attrs['pll_bandwidth_hz']):g} Hz) and MM Kalman filter, 1-ms prompts, "
                 f"carrier-aided DLL (B$_L$ = {float(tracking.attrs['dll_bandwidth_hz']):g} Hz); rows: the {n} highest mean C/N$_0$",
                 fontsize=8.5)
    fig.tight_layout()
    figure_legend(fig, *handles_of(*axes[:n].ravel(), summary), ncol=3, fontsize=7.5)
    return fig


def _summary_panel(ax, tracking: xr.Dataset, rows: list[int]) -> None:
    prns = tracking["prn"].values
    cn0 = tracking["mean_cn0_dbhz"].values
    lock = tracking["lock_fraction"].values
    edges = tracking["edge_fraction"].values
    n_edges = tracking["n_bit_edges"].values
    x = np.arange(prns.size)
    shown = np.isin(x, rows)
    ax.bar(x[shown], cn0[shown], width=0.6, color="tab:blue", label="drawn above")
    if (~shown).any():
        ax.bar(x[~shown], cn0[~shown], width=0.6, color="0.7", label="not drawn above")
    for i in x:
        ax.annotate(f"lock {lock[i]:.2f}\nedges {edges[i]:.2f}\n({int(n_edges[i])} seen)", (i, cn0[i]), xytext=(0, 2), textcoords="offset points",
                    ha="center", va="bottom", fontsize=MIN_FONT_PT)
    ax.set_xticks(x)
    ax.set_xticklabels([f"PRN {int(p)}" for p in prns], fontsize=8)
    low = float(np.nanmin(cn0)) if np.isfinite(cn0).any() else 30.0
    high = float(np.nanmax(cn0)) if np.isfinite(cn0).any() else 50.0
    ax.set_ylim(5 * math.floor((low - 8) / 5), high + 13)
    ax.set_ylabel("mean C/N$_0$ [dB-Hz]", fontsize=8)
    ax.set_title("every tracked satellite after the pull-in: mean C/N$_0$, lock fraction, share of the sign changes\n"
                 "on the bit-edge phase (data transitions seen)", fontsize=8)
    ax.grid(axis="x", visible=False)


def verdict_tracking(tracking: xr.Dataset, acquisition: xr.Dataset) -> Verdict:
    """No paper figure.  The line counts the satellites in lock over at least 90 % of the epochs after the pull-in and
    those whose sign changes fall on one 20-ms bit phase at least 90 % of the time, with the C/N0 range."""
    n = tracking.sizes["prn"]
    lock, edges, cn0 = tracking["lock_fraction"].values, tracking["edge_fraction"].values, tracking["mean_cn0_dbhz"].values
    good_lock = int(np.sum(lock >= GOOD_LOCK))
    good_edges = int(np.sum(np.nan_to_num(edges) >= GOOD_EDGES))
    return Verdict("no paper figure",
                   f"{n} satellites tracked (C/N0 {np.nanmin(cn0):.1f}-{np.nanmax(cn0):.1f} dB-Hz): {good_lock} in lock over >= "
                   f"{GOOD_LOCK:.0%} of the epochs after the {float(tracking.attrs['pull_in_ms']):g}-ms pull-in, {good_edges} with >= "
                   f"{GOOD_EDGES:.0%} of their sign changes on one bit phase")


figure("real_fig_tracking_pocketsdr_iq", "tracking_pocketsdr_4mhz_iq", paper=REAL_PAPER, section=SECTION,
       inputs=lambda c: {"tracking": paths.real_tracking_path(TRACKED_CAPTURE), "acquisition": paths.real_acquisition_path(TRACKED_CAPTURE)},
       number=None,
       claim="No paper figure: the project's Costas PLL, MM Kalman filter, DLL, C/N0 estimator and bit synchronisation track the "
             "satellites of a real 0.5-s Pocket SDR capture",
       verdict=verdict_tracking)(tracking_figure)
