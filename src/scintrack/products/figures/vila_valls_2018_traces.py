"""Figures 10-15 of Vila-Valls et al. 2018 (Sec. VI-E, multi-frequency traces).

Each function takes the result Datasets of its rule and returns a figure.
The data source (``attrs["source"]``: "real" or "surrogate") is named on a
line of its own in every title (:func:`~.conventions.data_title`): with the
default configuration the traces are a SYNTHETIC SURROGATE (phase screen),
not the JRC Hanoi recordings of the paper, and the titles say so.
Registered with the workflow by the decorators (:mod:`scintrack.products`);
their files get the ``_surrogate`` suffix when the traces are the surrogate.

Choices a reader could question, and why:

* Scintillation classes use the paper's S4 thresholds (Sec. III-A,
  :mod:`scintrack.models.regions`): S4 <= 0.3 weak ("low"), 0.3 < S4 <= 0.6
  moderate, S4 > 0.6 severe.  A PACF segment is labelled by the class its
  own S4 falls in, beside the paper's row it stands for (Figs. 13-14).
* Amplitudes in dB are ``20 log10(rho_s)`` with ``rho_s`` normalised to unit
  mean power, so 0 dB is the mean power (Fig. 10).
* Phase errors are wrapped to (-pi, pi] and drawn in rad, as in the paper's
  Fig. 15 and Table VI.  A tracker whose loop has run away (its unwrapped
  error drifts steadily, i.e. it no longer follows the Doppler) is cut where
  that happens and marked "lock lost" (:func:`lock_lost_time`), instead of
  drawing uniform noise (wrapped) or 10^8 cycles (unwrapped).
* Every verdict on surrogate data is "not reproduced": the surrogate was
  generated to the paper's event descriptions, so agreement or disagreement
  with the paper's figures says nothing about the Hanoi events.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ...labels import tracker_label, tracker_labels
from ...models.regions import region_of
from ...pipeline import paths
from ..registry import Verdict, figure
from ..tables.paper_values import VILA_VALLS_2018_TABLE_I, VILA_VALLS_2018_TABLE_V, VILA_VALLS_2018_TABLE_VI
from .common import new_figure
from .conventions import MIN_FONT_PT, NO_LOCK_RMSE_2PI, data_title, figure_legend, mark_lock_lost, until_lock_lost
from .vila_valls_2018 import LOSS_OF_LOCK_RAD

if TYPE_CHECKING:
    import xarray as xr

PAPER = "vila_valls_2018"
SEC_TRACES = "Sec. VI-E: real traces"

BAND_COLOURS = {"L1": "C0", "L2": "C1", "L5": "C2"}

#: the paper's fade statement for Fig. 10: "fadings as deep as -30 dB"
PAPER_DEEPEST_FADE_DB = -30.0
#: reference level of Fig. 10: the paper counts fadings below -10 dB
FADE_LEVEL_DB = -10.0
#: the paper's S4 description of its three events (Sec. VI-E, Fig. 12)
PAPER_EVENT_CLASSES = {"event1": ("severe",), "event2": ("severe",), "event3": ("moderate", "severe")}
PAPER_EVENT_WORDS = {"event1": "severe", "event2": "severe", "event3": "moderate to strong"}
#: length of the zoom window of Fig. 11
ZOOM_S = 5.0
#: a loop has lost lock when its unwrapped error drifts faster than this (cycles/s = Hz) over LOCK_DRIFT_WINDOW_S
LOCK_DRIFT_HZ = 2.0
LOCK_DRIFT_WINDOW_S = 2.0
#: ... and counts as in lock again only after LOCK_HOLD_S below it
LOCK_HOLD_S = 10.0


def _rt(config):
    return config["real_traces"]


def _diag(config):
    return {"diag": paths.trace_diagnostics_path(config)}


def _kind(ds: xr.Dataset) -> str:
    return "real" if ds.attrs.get("source") == "real" else "surrogate"


def _data_line(ds: xr.Dataset) -> str:
    """The title line naming the data (:func:`~.conventions.data_title`)."""
    if _kind(ds) == "real":
        return data_title("real") + " (JRC Hanoi)"
    return data_title("surrogate") + ", phase-screen model"


def _surrogate_words(ds: xr.Dataset) -> str:
    return "surrogate data, cannot confirm the paper: " if _kind(ds) == "surrogate" else ""


# --------------------------------------------------------------------------- Fig. 10


def _fade_stats(t: np.ndarray, rho: np.ndarray) -> tuple[np.ndarray, float, float, int]:
    """(amplitude in dB, deepest fade in dB, its time, number of fades below ``FADE_LEVEL_DB``).

    A fade is counted once per downward crossing of the level.
    """
    db = 20 * np.log10(np.maximum(rho, 1e-6))
    k = int(np.argmin(db))
    below = db < FADE_LEVEL_DB
    n = int(np.count_nonzero(below[1:] & ~below[:-1]) + (1 if below.size and below[0] else 0))
    return db, float(db[k]), float(t[k]), n


def _window(trace, start_s, length_s):
    t = trace["time"].values
    return t, (t >= start_s) & (t < start_s + length_s)


def _fig10_verdict(trace, start_s: float = 0.0, length_s: float = 100.0) -> Verdict:
    """Deepest fade and number of fades below -10 dB of each band in the window, against the paper's
    "fadings as deep as -30 dB".  Real traces: "reproduced" when the deepest fade over the bands is within
    5 dB of -30 dB, "differs" otherwise.  Surrogate: "not reproduced" (the surrogate is not the paper's data)."""
    t, sel = _window(trace, start_s, length_s)
    deep, count = [], []
    for band in trace["band"].values:
        _, d, _, n = _fade_stats(t[sel], trace["amplitude"].sel(band=band).values[sel].astype(float))
        deep.append(d)
        count.append(n)
    bands = "/".join(str(b) for b in trace["band"].values)
    text = (f"{_surrogate_words(trace)}deepest fade {bands} {'/'.join(f'{d:.1f}' for d in deep)} dB, "
            f"{'/'.join(str(n) for n in count)} fades below {FADE_LEVEL_DB:g} dB in {length_s:g} s, "
            f"vs paper 'as deep as {PAPER_DEEPEST_FADE_DB:g} dB'")
    if _kind(trace) == "surrogate":
        return Verdict("not reproduced", text)
    return Verdict("reproduced" if abs(min(deep) - PAPER_DEEPEST_FADE_DB) <= 5.0 else "differs", text)


@figure("fig10", "fig10_trace_amplitude_bands", paper=PAPER, section=SEC_TRACES, trace=True,
        inputs=lambda c: {"trace": paths.trace_path(c, _rt(c)["fig10"]["event"])},
        kwargs=lambda c: {"start_s": _rt(c)["fig10"]["start_s"], "length_s": _rt(c)["fig10"]["length_s"]},
        number="Fig. 10",
        claim="100 s of strong-event amplitude at L1, L2 and L5: fades reach about -30 dB and drops below -10 dB are frequent",
        tables=(), verdict=_fig10_verdict)
def fig10(trace, start_s: float = 0.0, length_s: float = 100.0):
    """100 s of amplitude at every band, in dB relative to the mean power.

    The y axis reaches below the deepest fade of the window (no fade is
    clipped); the deepest fade of each band is marked with its depth, and the
    paper's -10 dB reference level is dotted, with the number of fades below it.
    """
    bands = list(trace["band"].values)
    fig, axes = new_figure(len(bands), 1, figsize=(6.6, 6.8))
    axes = np.atleast_1d(axes)
    t, sel = _window(trace, start_s, length_s)
    stats = {}
    for band in bands:
        stats[band] = _fade_stats(t[sel], trace["amplitude"].sel(band=band).values[sel].astype(float))
    deepest = min(s[1] for s in stats.values())
    highest = max(float(np.max(s[0])) for s in stats.values())
    bottom = min(-40.0, 5.0 * np.floor((deepest - 2.0) / 5.0))  # at least 2 dB below the deepest fade
    top = max(10.0, 5.0 * np.ceil(highest / 5.0))
    for ax, band in zip(axes, bands):
        db, d, td, n = stats[band]
        colour = BAND_COLOURS.get(str(band), "C0")
        ax.plot(t[sel], db, lw=0.6, color=colour)
        ax.axhline(FADE_LEVEL_DB, color="0.3", ls=":", lw=0.9)
        ax.annotate(f"{d:.1f} dB", xy=(td, d), xytext=(10, -1), textcoords="offset points", fontsize=MIN_FONT_PT + 1,
                    va="center", arrowprops={"arrowstyle": "->", "color": "k", "lw": 0.8})
        ax.set_ylabel(f"{band} amplitude [dB]")
        ax.set_title(f"{band}: deepest fade {d:.1f} dB at {td:.1f} s; {n} fades below {FADE_LEVEL_DB:g} dB (dotted)",
                     fontsize=8)
        ax.set_ylim(bottom, top)
        ax.set_xlim(start_s, start_s + length_s)
    axes[-1].set_xlabel("time from the start of the trace [s]")
    fig.suptitle(f"Fig. 10: scintillation amplitude, {trace.attrs['event']}, 20 log$_{{10}}\\rho_s$ "
                 f"(0 dB = mean power)\n{_data_line(trace)}", fontsize=10)
    fig.tight_layout()
    return fig


# --------------------------------------------------------------------------- Fig. 11


def _wrap(x: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * x))


def zoom_window(t: np.ndarray, err: np.ndarray, length_s: float = ZOOM_S) -> tuple[float, float]:
    """(start, end) of the non-overlapping ``length_s`` window whose RMS of ``err`` is the median over all
    such windows (the lower median for an even count): a window that shows typical tracking, neither the best
    nor the worst."""
    ts = float(t[1] - t[0]) if t.size > 1 else 1.0
    n = max(int(round(length_s / ts)), 1)
    k = max(t.size // n, 1)
    rms = np.array([np.sqrt(np.nanmean(err[i * n : (i + 1) * n] ** 2)) for i in range(k)])
    order = np.argsort(rms, kind="stable")
    i = int(order[(k - 1) // 2])
    return float(t[i * n]), float(t[min((i + 1) * n, t.size) - 1])


def _fig11_verdict(static, band: str = "L1") -> Verdict:
    """AEKF-AR amplitude and (wrapped) phase RMSE over the evaluation segment and every realisation (the
    Table V cells of the event and band), against the paper's Table V.  Real traces: "reproduced" when both
    are within a factor 2 of the paper's, "differs" otherwise.  Surrogate: "not reproduced"."""
    d = static.sel(band=band)
    ev = static.attrs["event"]
    rho, theta = float(d["rmse_rho"]), float(d["rmse_theta"])
    paper = VILA_VALLS_2018_TABLE_V.get(ev, {}).get(str(band))
    text = f"{_surrogate_words(static)}AEKF-AR E_rho {rho:.3g}, E_theta {theta:.3g} rad ({ev} {band})"
    if paper is None:
        return Verdict("not reproduced" if _kind(static) == "surrogate" else "differs", text + "; the paper gives no value here")
    text += f" vs paper {paper[0]:.3g}, {paper[1]:.3g} rad"
    if _kind(static) == "surrogate":
        return Verdict("not reproduced", text)
    ok = all(0.5 <= ours / p <= 2.0 for ours, p in ((rho, paper[0]), (theta, paper[1])))
    return Verdict("reproduced" if ok else "differs", text)


@figure("fig11", "fig11_static_scintillation_tracking", paper=PAPER, section=SEC_TRACES, trace=True,
        inputs=lambda c: {"static": paths.trace_static_path(c, _rt(c)["fig11"]["event"])}, kwargs=lambda c: {"band": _rt(c)["fig11"]["band"]},
        number="Fig. 11",
        claim="Without dynamics, the AEKF-AR follows the measured scintillation amplitude and phase of event 1 at L1",
        tables=("table05",), verdict=_fig11_verdict)
def fig11(static, band: str = "L1"):
    """True and AEKF-AR-estimated amplitude and phase (dynamics-free), first realisation, with a zoom.

    Left: the whole evaluation segment; right: a ``ZOOM_S`` window (shaded on
    the left) chosen by :func:`zoom_window` on the wrapped phase error, so it
    shows typical tracking.  The phase estimate is drawn as the filter gives
    it (not re-aligned by whole cycles): a drift by whole cycles is part of
    what the filter does.  The amplitude estimate can be negative (the
    (rho, theta) -> (-rho, theta + pi) ambiguity of the I/Q model); 0 is
    drawn.  The panel titles give the Table V RMSE over every realisation.
    """
    import matplotlib.patches as mpatches

    d = static.sel(band=band)
    t = static["time"].values
    rho_t, rho_h = d["example_rho_true"].values, d["example_rho_hat"].values
    th_t, th_h = d["example_theta_true"].values, d["example_theta_hat"].values
    z0, z1 = zoom_window(t, _wrap(th_h - th_t))
    zsel = (t >= z0) & (t <= z1)
    fig, axes = new_figure(2, 2, figsize=(8.0, 5.8), gridspec_kw={"width_ratios": (2.0, 1.0)})
    label = tracker_label(static, next(iter(tracker_labels(static)), "aekf_ar_static"), for_figure=True)
    rows = ((0, rho_t, rho_h, r"amplitude $\rho_s$ (unit mean power)"), (1, th_t, th_h, r"phase $\theta_s$ [rad]"))
    handles = []
    for r, truth, est, ylab in rows:
        for c, mask in ((0, slice(None)), (1, zsel)):
            ax = axes[r, c]
            h1, = ax.plot(t[mask], truth[mask], lw=0.7, color="k", label="trace (truth)")
            h2, = ax.plot(t[mask], est[mask], lw=0.7, ls="--", color="C1", label=f"{label} estimate")
            if r == 0:
                ax.axhline(0.0, color="0.5", lw=0.6)
            if c == 0:
                ax.axvspan(z0, z1, color="C2", alpha=0.35, lw=0)
                ax.set_ylabel(ylab)
                ax.set_xlim(t[0], t[-1])
            else:
                ax.set_xlim(z0, z0 + ZOOM_S)
            if not handles:
                handles = [h1, h2]
    rmse_rho, rmse_theta = float(d["rmse_rho"]), float(d["rmse_theta"])
    n_tr = static.sizes.get("trial", 1)
    paper = VILA_VALLS_2018_TABLE_V.get(static.attrs["event"], {}).get(str(band))
    p_rho = f"; paper {paper[0]:.3g}" if paper else ""
    p_theta = f"; paper {paper[1]:.3g} rad" if paper else ""
    axes[0, 0].set_title(f"E$_\\rho$ = {rmse_rho:.2f} (RMSE over {n_tr} realisations{p_rho})", fontsize=8)
    axes[1, 0].set_title(f"E$_\\theta$ = {rmse_theta:.2f} rad (wrapped, {n_tr} realisations{p_theta}; no lock {NO_LOCK_RMSE_2PI:.2f})",
                         fontsize=8)
    axes[0, 1].set_title(f"zoom: {ZOOM_S:g} s from {z0:g} s (median-error window)", fontsize=8)
    axes[1, 1].set_title("zoom, same window", fontsize=8)
    for c in (0, 1):
        axes[1, c].set_xlabel("time after the fitting segment [s]")
    fig.suptitle(
        f"Fig. 11: dynamics-free AEKF-AR tracking, {static.attrs['event']} {band}, C/N$_0$ = {static.attrs['cn0_dbhz']:g} dB-Hz, "
        f"realisation 0\n{_data_line(static)}", fontsize=10,
    )
    fig.tight_layout()
    zoom_patch = mpatches.Patch(color="C2", alpha=0.35, lw=0)
    figure_legend(fig, [*handles, zoom_patch], [h.get_label() for h in handles] + ["zoom window"], ncol=3)
    return fig


# --------------------------------------------------------------------------- Fig. 12


def _event_means(diag) -> dict[str, float]:
    """Mean L1 (first band) S4 over the sliding windows of each event."""
    b0 = diag["band"].values[0]
    return {str(ev): float(np.nanmean(diag["s4"].sel(event=ev, band=b0).values)) for ev in diag["event"].values}


def _fig12_verdict(diag) -> Verdict:
    """Mean L1 S4 of each event and its class by the paper's thresholds, against the paper's description
    (events 1 and 2 severe, event 3 moderate to strong).  Real traces: "reproduced" when every class matches,
    "differs" otherwise.  Surrogate: "not reproduced" (its S4 was set from that description)."""
    means = _event_means(diag)
    parts = [f"{ev} {m:.3f} ({region_of(m)}; paper {PAPER_EVENT_WORDS.get(ev, '?')})" for ev, m in means.items()]
    text = f"{_surrogate_words(diag)}mean L1 S4 " + ", ".join(parts)
    if _kind(diag) == "surrogate":
        return Verdict("not reproduced", text + "; the surrogate was generated to these classes")
    ok = all(region_of(m) in PAPER_EVENT_CLASSES.get(ev, (region_of(m),)) for ev, m in means.items())
    return Verdict("reproduced" if ok else "differs", text)


@figure("fig12", "fig12_trace_s4", paper=PAPER, section=SEC_TRACES, trace=True, inputs=_diag,
        number="Fig. 12",
        claim="S4 of the three events: events 1 and 2 are severe, event 3 is moderate to strong",
        tables=(), verdict=_fig12_verdict)
def fig12(diag):
    """S4 against time of every event (all bands), with the paper's class limits.

    The dotted lines are the paper's thresholds (0.3: weak/moderate,
    0.6: moderate/severe); each panel's title gives the mean L1 S4 and its class.
    """
    from matplotlib.lines import Line2D

    events = list(diag["event"].values)
    fig, axes = new_figure(len(events), 1, figsize=(6.6, 6.8))
    axes = np.atleast_1d(axes)
    t = diag["s4_time"].values
    means = _event_means(diag)
    top = max(1.6, float(np.ceil(np.nanmax(diag["s4"].values) * 5.0) / 5.0))
    for ax, ev in zip(axes, events):
        for band in diag["band"].values:
            ax.plot(t, diag["s4"].sel(event=ev, band=band).values, lw=1.0, color=BAND_COLOURS.get(str(band)))
        for level in (0.3, 0.6):
            ax.axhline(level, color="0.3", ls=":", lw=0.9)
        m = means[str(ev)]
        ax.set_title(f"{ev}: mean L1 S$_4$ = {m:.3f} ({region_of(m)}); paper: {PAPER_EVENT_WORDS.get(str(ev), 'not given')}",
                     fontsize=8)
        ax.set_ylabel("S$_4$")
        ax.set_ylim(0, top)
        ax.set_xlim(t[0], t[-1])
    axes[-1].set_xlabel("time from the start of the trace [s] (window centre)")
    window = diag["s4"].attrs.get("long_name", "")
    fig.suptitle(f"Fig. 12: S$_4$ index of the three events ({window})\n{_data_line(diag)}", fontsize=10)
    fig.tight_layout()
    handles = [Line2D([], [], color=BAND_COLOURS.get(str(b)), lw=1.2) for b in diag["band"].values]
    handles.append(Line2D([], [], color="0.3", ls=":", lw=0.9))
    labels = [str(b) for b in diag["band"].values] + ["class limits (paper)"]
    figure_legend(fig, handles, labels, ncol=len(labels))
    return fig


# --------------------------------------------------------------------------- Figs. 13-14


def _weak_available(diag) -> bool:
    """Whether any sliding L1 window of any event has S4 <= 0.3 (weak by the paper's thresholds)."""
    return bool(np.nanmin(diag["s4"].sel(band=diag["band"].values[0]).values) <= 0.3)


def _segment_orders(diag, component: str) -> list[tuple[str, float, int, int]]:
    """(segment, S4, order from the PACF, paper's Table I order for the segment's actual class) per segment."""
    from ...models.ar import pacf_order

    out = []
    for seg in diag["segment"].values:
        v = diag["pacf"].sel(segment=seg, component=component).values
        b = diag["pacf_bound"].sel(segment=seg, component=component).values
        s4 = float(diag["segment_s4"].sel(segment=seg))
        out.append((str(seg), s4, pacf_order(v, b), VILA_VALLS_2018_TABLE_I[region_of(s4)][component]))
    return out


def _pacf_verdict(diag, component: str) -> Verdict:
    """Order read from the sample PACF (first lag inside the 95% band, minus one) of each segment, against the
    paper's Table I order for the segment's S4 class.  Real traces: "reproduced" when every order matches,
    "differs" otherwise.  Surrogate: "not reproduced"."""
    rows = _segment_orders(diag, component)
    lags = int(diag["lag"].values[-1])
    parts = [f"{seg} (S4 {s4:.2f}, {region_of(s4)}) {'>=' if o >= lags else ''}{o} vs paper AR({p})" for seg, s4, o, p in rows]
    text = f"{_surrogate_words(diag)}PACF order of the {component}: " + ", ".join(parts)
    if not _weak_available(diag):
        text += "; the data have no weak (S4 <= 0.3) segment"
    if _kind(diag) == "surrogate":
        return Verdict("not reproduced", text)
    return Verdict("reproduced" if all(o == p for _, _, o, p in rows) else "differs", text)


def _fig13_verdict(diag, component: str = "amplitude", ts: float | None = None) -> Verdict:
    """See :func:`_pacf_verdict` (amplitude)."""
    return _pacf_verdict(diag, component)


def _fig14_verdict(diag, component: str = "phase", ts: float | None = None) -> Verdict:
    """See :func:`_pacf_verdict` (phase)."""
    return _pacf_verdict(diag, component)


def _pacf(diag, component: str, fig_no: int, ts: float | None = None):
    """Sample PACF of the three L1 segments (paper's rows: severe, moderate, low), drawn like Figs. 2 and 4.

    The segments are chosen by the diagnostics step (the most severe 60 s L1
    window of the three events, the one nearest S4 = 0.45, the lowest).  Each
    panel says which of the paper's rows it stands for and the class its own S4
    falls in; when no window of the data is weak, the "low" row shows the
    lowest-S4 window there is, and its title says it is not weak.  Filled
    markers are outside the 95% band; the order read from the PACF (first lag
    inside the band, minus one) is given beside the paper's Table I order for
    that class.  The amplitude and phase PACFs (Figs. 13 and 14) come from the
    two different series of the same segments.
    """
    from matplotlib.lines import Line2D

    segs = list(diag["segment"].values)
    fig, axes = new_figure(len(segs), 1, figsize=(6.6, 7.6))
    axes = np.atleast_1d(axes)
    lags_all = diag["lag"].values
    orders = {seg: (o, p) for seg, _s4, o, p in _segment_orders(diag, component)}
    weak = _weak_available(diag)
    for ax, seg in zip(axes, segs):
        v = diag["pacf"].sel(segment=seg, component=component).values[1:]
        b = diag["pacf_bound"].sel(segment=seg, component=component).values[1:]
        lags = lags_all[1:]
        outside = np.abs(v) > b
        ax.vlines(lags, 0, v, color="C0", lw=1.5)
        ax.plot(lags[outside], v[outside], "o", color="C0", ms=5)
        ax.plot(lags[~outside], v[~outside], "o", mfc="white", color="C0", ms=5)
        ax.plot(lags, b, "--", color="tab:red", lw=1.0)
        ax.plot(lags, -b, "--", color="tab:red", lw=1.0)
        ax.axhline(0, color="k", lw=0.6)
        ax.set_ylim(-1.05, 1.05)
        ax.set_xticks(lags)
        ax.set_ylabel("partial autocorrelation")
        s4 = float(diag["segment_s4"].sel(segment=seg))
        cls = region_of(s4)
        note = ""
        if seg == "low" and cls != "low":
            note = " - not weak; no S$_4$ in Fig. 12 is $\\leq$ 0.3" if not weak else " - not weak"
        o, p = orders[seg]
        at_least = "$\\geq$" if o >= lags[-1] else ""
        ax.set_title(
            f"paper's '{seg}' row: {diag['segment_event'].sel(segment=seg).item()} L1, {diag.attrs['segment_s']:g} s from "
            f"{float(diag['segment_start_s'].sel(segment=seg)):g} s, S$_4$ = {s4:.2f} ({cls}){note}\n"
            f"order from the PACF: {at_least}{o}; paper (Table I, {cls}): AR({p})",
            fontsize=8,
        )
    axes[-1].set_xlabel(f"lag [samples of {ts * 1e3:g} ms]" if ts else "lag [samples]")
    fig.suptitle(f"Fig. {fig_no}: sample PACF of the scintillation {component}, L1\n{_data_line(diag)}", fontsize=10)
    fig.tight_layout()
    handles = [Line2D([], [], color="C0", marker="o", ls="none", ms=5), Line2D([], [], color="C0", marker="o", mfc="white", ls="none", ms=5),
               Line2D([], [], color="tab:red", ls="--", lw=1.0)]
    figure_legend(fig, handles, ["outside the 95% band", "inside the band", "95% band"], ncol=3)
    return fig


@figure("fig13", "fig13_trace_amplitude_pacf", paper=PAPER, section=SEC_TRACES, trace=True, inputs=_diag, kwargs=lambda c: {"component": "amplitude", "ts": float(c["sampling"]["ts"])},
        number="Fig. 13",
        claim="The sample PACF of measured amplitude in severe, moderate and low scintillation supports an AR(3) amplitude model",
        tables=(), verdict=_fig13_verdict)
def fig13(diag, component: str = "amplitude", ts: float | None = None):
    """Sample PACF of the scintillation amplitude of three L1 segments (severe, moderate, lowest S4; :func:`_pacf`)."""
    return _pacf(diag, component, 13, ts)


@figure("fig14", "fig14_trace_phase_pacf", paper=PAPER, section=SEC_TRACES, trace=True, inputs=_diag, kwargs=lambda c: {"component": "phase", "ts": float(c["sampling"]["ts"])},
        number="Fig. 14",
        claim="The sample PACF of measured phase supports a phase AR order that falls from 3 (low) to 1 (severe)",
        tables=(), verdict=_fig14_verdict)
def fig14(diag, component: str = "phase", ts: float | None = None):
    """Sample PACF of the scintillation phase of three L1 segments (severe, moderate, lowest S4; :func:`_pacf`)."""
    return _pacf(diag, component, 14, ts)


# --------------------------------------------------------------------------- Fig. 15


def lock_lost_time(t: np.ndarray, unwrapped: np.ndarray, *, drift_hz: float = LOCK_DRIFT_HZ,
                   window_s: float = LOCK_DRIFT_WINDOW_S, hold_s: float = LOCK_HOLD_S) -> float | None:
    """When the loop lost lock for good (None: never), from its unwrapped phase error in rad.

    The error's drift over the last ``window_s`` (cycles per second: the
    loop's mean frequency error) must stay below ``drift_hz`` for at least
    ``hold_s`` for the loop to count as in lock: a loop that slips a cycle and
    relocks drifts by about one cycle over the window and is still tracking,
    while a runaway loop's frequency error only passes through zero for an
    instant when the Doppler profile turns.  Lock is lost for good from the
    first epoch after the last in-lock stretch
    (:func:`~.conventions.until_lock_lost` on the drift, with in-bound
    stretches shorter than ``hold_s`` counted as out of bound, except at the
    start and end of the trace, where the stretch is cut by the trace itself).
    """
    t = np.asarray(t, dtype=float)
    e = np.asarray(unwrapped, dtype=float)
    if t.size < 2:
        return None
    ts = float(t[1] - t[0])
    n = max(int(round(window_s / ts)), 1)
    if e.size <= n:
        return None
    drift = np.zeros_like(e)
    drift[n:] = np.abs(e[n:] - e[:-n]) / (2 * np.pi * window_s)
    drift[~np.isfinite(drift)] = np.inf
    inside = drift <= drift_hz
    hold = max(int(round(hold_s / ts)), 1)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], inside.astype(np.int8), [0]))))
    for start, stop in zip(edges[::2], edges[1::2]):
        if stop - start < hold and 0 < start and stop < e.size:
            drift[start:stop] = np.inf
    _, t_lost = until_lock_lost(t, drift, drift_hz)
    return t_lost


def _wrapped_until_lost(t: np.ndarray, unwrapped: np.ndarray) -> tuple[np.ndarray, float | None]:
    """The error wrapped to (-pi, pi], NaN after lock was lost and at every wrap (no vertical jumps)."""
    t_lost = lock_lost_time(t, unwrapped)
    w = _wrap(np.asarray(unwrapped, dtype=float))
    if t_lost is not None:
        w[t >= t_lost] = np.nan
    jump = np.zeros(w.size, dtype=bool)
    jump[1:] = np.abs(np.diff(w)) > np.pi
    w[jump] = np.nan
    return w, t_lost


def _paper_rmse(event: str, band: str, tracker: str, res) -> float | None:
    """The paper's Table VI RMSE of ``tracker`` (trace variants ``*_trace`` map to the paper's tracker)."""
    row = VILA_VALLS_2018_TABLE_VI.get(event, {}).get(tracker.removesuffix("_trace"))
    bands = [str(b) for b in res["band"].values]
    j = bands.index(band) if band in bands else None
    return row[j] if row is not None and j is not None and j < len(row) else None


def _fig15_verdict(*results, cases=()) -> Verdict:
    """Wrapped theta_d RMSE of the AEKF-AR over every realisation (the Table VI cells) on the two cases,
    against the paper's Table VI, and which trackers are below the 0.52 rad rule of thumb (paper: only the
    AEKF-AR).  Real traces: "reproduced" when the AEKF-AR is the only tracker below 0.52 rad in both cases,
    "differs" otherwise.  Surrogate: "not reproduced"."""
    parts, only_aekf = [], True
    for res, (event, band) in zip(results, cases):
        d = res.sel(band=band, kind="wrapped")
        rmse = {str(tr): float(d["steady_rmse"].sel(tracker=tr)) for tr in d["tracker"].values}
        aekf = next((tr for tr in rmse if tr.startswith("aekf_ar")), None)
        below = [tracker_label(res, tr) for tr, v in rmse.items() if v < LOSS_OF_LOCK_RAD]
        only_aekf &= aekf is not None and below == [tracker_label(res, aekf)]
        paper = _paper_rmse(event, band, aekf, res) if aekf is not None else None
        best = min(rmse, key=rmse.get)
        parts.append(f"{event} {band}: AEKF-AR {rmse.get(aekf, float('nan')):.2f} rad"
                     + (f" vs paper {paper:.3g}" if paper is not None else "")
                     + f", best {tracker_label(res, best)} {rmse[best]:.2f}, {len(below)} below {LOSS_OF_LOCK_RAD:g} rad")
    text = _surrogate_words(results[0]) + "; ".join(parts)
    if _kind(results[0]) == "surrogate":
        return Verdict("not reproduced", text)
    return Verdict("reproduced" if only_aekf else "differs", text)


@figure("fig15", "fig15_trace_phase_error", paper=PAPER, section=SEC_TRACES, trace=True,
        inputs=lambda c: {f"{e}_{b}": paths.trace_dynamics_path(c, e) for e, b in _rt(c)["fig15"]},
        kwargs=lambda c: {"cases": [list(case) for case in _rt(c)["fig15"]]},
        number="Fig. 15",
        claim="On event 1 L1 and event 3 L2 with aeronautical dynamics, only the AEKF-AR keeps its phase error under the 0.52 rad loss-of-lock threshold",
        tables=("table06",), verdict=_fig15_verdict)
def fig15(*results, cases=()):
    """Dynamics phase error (wrapped, rad, first realisation) of every tracker on two event/band cases.

    One panel per tracker (rows) and case (columns), so five noisy traces do
    not hide one another.  The error is wrapped to (-pi, pi] (the paper's
    Fig. 15 and Table VI convention), drawn without the vertical jumps of the
    wrap; a loop that has run away is cut where it lost lock for good and
    marked (:func:`lock_lost_time`).  The dotted band is the paper's
    0.52 rad loss-of-lock rule of thumb; each panel's title gives the Table VI
    RMSE (wrapped, every realisation) of that tracker.
    """
    from matplotlib.lines import Line2D

    trackers = [str(tr) for tr in results[0]["tracker"].values]
    fig, axes = new_figure(len(trackers), len(cases), figsize=(8.4, 1.6 * len(trackers) + 1.4),
                           squeeze=False)
    ticks = [-np.pi, -np.pi / 2, 0.0, np.pi / 2, np.pi]
    tick_labels = ["$-\\pi$", "$-\\pi/2$", "0", "$\\pi/2$", "$\\pi$"]
    lost_any = False
    for c, (res, (event, band)) in enumerate(zip(results, cases)):
        d = res.sel(band=band)
        t = d["time"].values
        for r, name in enumerate(trackers):
            ax = axes[r, c]
            colour = f"C{r}"
            w, t_lost = _wrapped_until_lost(t, d["example_error"].sel(tracker=name).values)
            ax.plot(t, w, lw=0.4, color=colour)
            for s in (-1, 1):
                ax.axhline(s * LOSS_OF_LOCK_RAD, color="k", ls=":", lw=0.9)
            if t_lost is not None:
                lost_any = True
                mark_lock_lost(ax, t_lost, 0.0, color="k")
            rmse = float(d["steady_rmse"].sel(tracker=name, kind="wrapped"))
            head = f"{event}, {band}, realisation {int(d['example_trial'])}\n" if r == 0 else ""
            paper = _paper_rmse(event, band, name, res)
            ax.set_title(f"{head}{tracker_label(res, name, for_figure=True)}: RMSE {rmse:.2f} rad over {int(d['n_trials'])} realisations"
                         + (f"; paper {paper:.3g} rad" if paper is not None else ""), fontsize=8)
            ax.set_ylim(-np.pi, np.pi)
            ax.set_yticks(ticks)
            ax.set_yticklabels(tick_labels)
            ax.set_xlim(t[0], t[-1])
            if c == 0:
                ax.set_ylabel(r"$\theta_d$ error [rad]")
        axes[-1, c].set_xlabel("time after the fitting segment [s]")
    fig.suptitle(f"Fig. 15: $\\theta_d$ error with aeronautical dynamics, wrapped to $(-\\pi, \\pi]$\n{_data_line(results[0])}",
                 fontsize=10)
    fig.tight_layout()
    handles = [Line2D([], [], color="k", ls=":", lw=0.9), Line2D([], [], color="none")]
    labels = [f"$\\pm${LOSS_OF_LOCK_RAD:g} rad: the paper's loss-of-lock rule of thumb",
              f"RMSE without lock: $\\pi/\\sqrt{{3}}$ = {NO_LOCK_RMSE_2PI:.2f} rad"]
    if lost_any:
        handles.append(Line2D([], [], color="k", marker="x", ms=8, mew=2, ls="none"))
        labels.append(f"lock lost for good (error drift > {LOCK_DRIFT_HZ:g} Hz over {LOCK_DRIFT_WINDOW_S:g} s)")
    figure_legend(fig, handles, labels, ncol=2)
    return fig
