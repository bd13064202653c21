"""Figures of Susi, Andreotti & Aquino 2014 (KF PLLs at 1 ms): Figs. 3-8 and the SAKF monitor.

* Figs. 3 and 6: S4 and Phi60 over 60-s windows, truth (noise-free trace)
  and as a receiver measures them (``results/susi_2014/indices``).  The
  receiver's Phi60 comes from a causal 0.1-Hz high-pass that starts from rest:
  the windows that start before its step response has settled
  (:func:`filter_settle_s`, 1 % of the step) are not drawn, as the chapter's
  Septentrio leaves out the first minutes of its Phi60 while its detrending
  filter converges (the caption line says which windows and why);
* Fig. 4: the discriminator output of the PLL, AKF PLL and SAKF PLL, one
  trial, high latitude, with a zoom on the largest excursion.  The chapter's
  metric for it is the standard deviation of the 1-ms output (its Fig. 5
  jitter); the results store the 1-ms std per 60-s window and the 10-ms means
  of one trial (what the panels draw).  Each panel title gives both numbers;
  the caption says why they rank the trackers differently: a 10-ms mean
  divides white noise by sqrt(10) and keeps slow errors, so it favours the
  loop whose error is whitest, the widest one;
* Figs. 5 and 8: the phase jitter per 60-s window, mean over trials: the
  chapter's discriminator jitter and the jitter of the true tracking error.
  The y axes start at 0 (a gap of 0.01 rad looks like one); the 95% interval
  of the mean is drawn as error bars and its largest half-width is written in
  the title, because it is narrower than the markers;
* Fig. 7: carrier Doppler against the truth, equatorial, one trial: a 10-s
  zoom (Doppler minus the line-of-sight line) centred on the SAKF's largest
  0.2-s jump of its error, and the RMS of estimate minus truth per 5-s block
  over the whole run (one line per tracker instead of three over-plotted
  noisy traces).  The truth drawn is the 0.1-s mean of the true Doppler (its
  10-ms means carry the receiver clock's white frequency noise, which no loop
  tracks).  The caption explains the SAKF's flat stretches and steps: while
  its 3-s power-law fit is steep (p of 4-4.6 in trial 0), eq. (7)
  ``S = T f_irr^-p``, extrapolated from the 0.5-5 Hz fit band down to
  f_irr = 0.19 Hz, puts up to a few hundred rad^2/s of process noise on the
  phase state; the filter then explains the scintillation with its phase
  state, its Doppler state keeps only the ramp (plateau), and when a 0.1-s
  refresh lowers T and p (S falls ~20-fold in trial 0 at 24.5 s) the Doppler
  state catches up in a step (found by re-running trial 0 of the SAKF with
  its monitors per trial; the results store only their trial means);
* SAKF monitor: the SAKF's on-line Phi3, power-law slope p and strength T
  (means, T median, over trials) beside the same quantities of the noise-free
  scintillation phase computed the SAKF's way (its 3-s window detrended by a
  least-squares quadratic, the power law fitted over its band), so like is
  compared with like; Phi3 of the ISMR convention (causal 0.1-Hz
  Butterworth, ``results/susi_2014/indices``) is drawn dashed beside them, and
  the caption gives the ratio of the two detrendings' Phi3 (the quadratic fit
  over 3 s removes the 0.1-0.3 Hz part that dominates a steep power law).
  The noise-free phase is read from the scenario's trace file (the
  ``trace_*`` inputs, cut as the runner cuts it: ``fit_s`` onwards for the
  scenario's duration);
* in-band strength (no chapter figure): the discriminator jitter of the three
  loops and its paired difference to the PLL against the scale of the
  scintillation phase (log axis, ticks at the scales), both scenarios, with
  the lowest tracker per scale in each panel title (``susi_table_inband``).

The high-latitude scintillation is always a SYNTHETIC SURROGATE; the
equatorial one is too unless the JRC traces are configured: every title says
which (``trace_source`` of the results).  Legends are below the panels
(:func:`~.conventions.figure_legend`); explanatory lines sit between the
panels and the legend (:func:`_caption`).

Verdicts: the chapter shows plots only and gives no number, so a verdict
compares the ranking or property the chapter states with ours.  On
surrogate data an agreement cannot confirm the chapter ("not reproduced",
the text says "surrogate data") and a disagreement is "differs"; on real
data an agreement is "reproduced".
"""

from __future__ import annotations

import math
import textwrap
from typing import TYPE_CHECKING

import numpy as np

from ...experiments.metrics import mean_with_ci
from ...labels import tex, tracker_labels
from ...pipeline import paths
from ..registry import Verdict, figure
from ..tables.susi_2014 import (
    AKF,
    CHAPTER,
    CLAIMS,
    METRICS,
    PAPER,
    REAL_INDICES,
    REFERENCE,
    SAKF,
    SECTION,
    experiment_scenarios,
    has_jitter,
    jitter_trackers,
    paired,
    real_event,
    real_indices_inputs,
    real_stations,
    scenario_is_surrogate,
    scenario_minutes,
    scenario_name,
    source_text,
    station_values,
    steady_windows,
    trial_jitter,
    ts_ms,
    window_length_s,
)
from ..tables.susi_2014 import (
    verdict as claim_verdict,
)
from .common import new_figure
from .conventions import MIN_FONT_PT, caption, figure_legend, handles_of, log_ticks

if TYPE_CHECKING:
    import xarray as xr

HIGH, EQUATORIAL = "susi_high_latitude", "susi_equatorial"
#: the high-latitude scenario on the real-index event, strength from Phi60 (the verdict's) and from Ts1 as given
EVENT, EVENT_T = "susi_high_latitude_event", "susi_high_latitude_event_T"
COLOURS = {"susi_pll": "C0", "susi_akf": "C1", "susi_sakf": "C2"}
WHERE = {HIGH: "high latitude", EQUATORIAL: "equatorial", EVENT: "real-index event (Phi60)", EVENT_T: "real-index event (Ts1)"}


def _colour(name: str, k: int) -> str:
    return COLOURS.get(name, f"C{k}")


def _label(ds: xr.Dataset, name: str) -> str:
    return tex(tracker_labels(ds).get(name, name))


def _plain(ds: xr.Dataset, name: str) -> str:
    return tracker_labels(ds).get(name, name)


def _where(ds: xr.Dataset) -> str:
    return WHERE.get(str(ds.attrs.get("scenario")), str(ds.attrs.get("scenario")))


def _cond(ds: xr.Dataset) -> str:
    return f"C/N$_0$ = {float(ds.attrs['cn0_dbhz']):g} dB-Hz, $T_s$ = {ts_ms(ds)} ms"


def _block_ms(ds: xr.Dataset) -> str:
    return f"{int(ds.attrs.get('stats_block_epochs', 1)) * float(ds.attrs['ts']) * 1000:g}"


def _steady_start(ds: xr.Dataset) -> float:
    return float(ds.attrs["steady_state_start_s"])


def _surrogate_data(ds: xr.Dataset) -> bool:
    return ds.attrs.get("trace_source") != "real"


def _agreement(surrogate: bool, holds: bool) -> str:
    """The status of a chapter claim: an agreement on surrogate data cannot confirm the chapter."""
    if not holds:
        return "differs"
    return "not reproduced" if surrogate else "reproduced"


def _data_words(surrogate: bool) -> str:
    return "surrogate data" if surrogate else "real JRC data"


def _show_x_ticks(axes) -> None:
    """Tick labels on every panel of a shared x axis (each panel is read on its own)."""
    for ax in np.ravel(axes):
        ax.tick_params(axis="x", labelbottom=True)


# --- Figs. 3 and 6: scintillation indices -----------------------------------------------------


def filter_settle_s(cutoff_hz: float, order: int = 6, fraction: float = 0.01) -> float:
    """Time after which the step response of the causal Butterworth high-pass (the receiver's Phi60
    detrending, :func:`scintrack.estimators.sigma_phi.detrend_sos`) stays within ``fraction`` of the step."""
    from scipy import signal

    fs = 200.0 * cutoff_hz  # 200 samples per cutoff period: ample for a step response
    n = int(round(60.0 / cutoff_hz * fs / 10.0 * 10))
    sos = signal.butter(order, cutoff_hz, btype="highpass", fs=fs, output="sos")
    step = signal.sosfilt(sos, np.ones(n))
    outside = np.flatnonzero(np.abs(step) > fraction)
    return float((outside[-1] + 1) / fs) if outside.size else 0.0


def _blanked_windows(ind: xr.Dataset) -> np.ndarray:
    """Windows of the receiver's Phi60 that start before its causal high-pass has settled."""
    w = np.asarray(ind["window"].values, dtype=float)
    start = w - float(ind.attrs["window_s"]) / 2
    return start < filter_settle_s(float(ind.attrs.get("detrend_hz", 0.1))) - 1e-9


def indices_figure(ind: xr.Dataset, fig_no: int):
    fig, (ax1, ax2) = new_figure(2, 1, figsize=(6.4, 5.6), sharex=True)
    t = ind["window"].values
    half = float(ind.attrs["window_s"]) / 2
    mon = str(ind.attrs.get("monitor_tracker", "PLL"))
    mon = "15-Hz PLL" if mon == REFERENCE else mon
    blank = _blanked_windows(ind)
    settle = filter_settle_s(float(ind.attrs.get("detrend_hz", 0.1)))
    for ax, key, name in ((ax1, "s4", "$S_4$"), (ax2, "phi60", r"$\Phi_{60}$ [rad]")):
        rx_values = np.asarray(ind[f"{key}_receiver"].values, dtype=float).copy()
        if key == "phi60":
            rx_values[blank] = np.nan
        ax.errorbar(t, ind[f"{key}_true"].values, xerr=half, fmt="o-", ms=4, lw=1.0, capsize=0, color="0.2",
                    label="truth: noise-free trace (bar: the 60-s window)")
        ax.errorbar(t, rx_values, xerr=half, fmt="s--", ms=4, lw=1.0, capsize=0, color="tab:red",
                    label=f"receiver: S$_4$ of the prompts (thermal noise removed); $\\Phi_{{60}}$ of the {mon} carrier phase "
                          "(dynamics removed, causal 0.1-Hz high-pass)")
        ax.set_ylabel(name)
        ax.set_ylim(bottom=0, top=1.15 * float(np.nanmax([np.nanmax(ind[f"{key}_true"].values), np.nanmax(rx_values)])))
        ax.set_xlabel("time [s]")
    _show_x_ticks((ax1, ax2))
    ax1.set_title("amplitude scintillation index $S_4$", fontsize=8.5)
    ax2.set_title(r"phase scintillation index $\Phi_{60}$", fontsize=8.5)
    fig.suptitle(f"Fig. {fig_no}: $S_4$ and $\\Phi_{{60}}$ over {float(ind.attrs['window_s']):g}-s windows, {_where(ind)} scenario\n"
                 f"{source_text(ind)}\n{_cond(ind)}; receiver: trial {int(ind.attrs['trial'])}", fontsize=9)
    fig.tight_layout()
    n_blank = int(blank.sum())
    if n_blank:
        first = "first window is" if n_blank == 1 else f"first {n_blank} windows are"
        caption(fig, f"The receiver's $\\Phi_{{60}}$ of the {first} not drawn: its causal "
                      f"0.1-Hz high-pass starts from rest and needs {settle:.0f} s to settle (1% of a step), so such a window holds the "
                      "filter's transient, not scintillation. The chapter's receiver leaves out its first minutes of $\\Phi_{60}$ for "
                      "the same reason.")
    figure_legend(fig, *handles_of(ax1), ncol=1, fontsize=7.5)
    return fig


def _indices_inputs(scenario: str):
    return lambda c: {"indices": paths.susi_indices_path(scenario)}


def _surrogate(*scenarios: str):
    return lambda c: any(scenario_is_surrogate(c, sc) for sc in scenarios)


#: (largest S4, smallest mean Phi60 [rad]) of the chapter's words per figure: Fig. 3 "S4 at noise level,
#: very high Phi60"; Fig. 6 "moderate amplitude, high phase variation"
INDEX_CLAIMS = {3: ((0.0, 0.2), 0.5), 6: ((0.2, 0.7), 0.5)}


def indices_verdict(ind: xr.Dataset, fig_no: int) -> Verdict:
    """Compares the noise-free S4 and Phi60 with the chapter's words (it gives no number).

    The chapter's words hold when every window's S4 lies in ``INDEX_CLAIMS[fig][0]`` (noise level:
    below 0.2; moderate: 0.2-0.7) and the mean Phi60 is at least ``INDEX_CLAIMS[fig][1]`` (0.5 rad,
    "high").  Surrogate data: "not reproduced" when they hold (the surrogate was generated to hold
    them), "differs" otherwise; real data: "reproduced" / "differs".
    """
    (s_lo, s_hi), phi_min = INDEX_CLAIMS[fig_no]
    s4 = np.asarray(ind["s4_true"].values, dtype=float)
    phi = np.asarray(ind["phi60_true"].values, dtype=float)
    holds = bool(np.all((s4 >= s_lo) & (s4 < s_hi)) and np.nanmean(phi) >= phi_min)
    surrogate = ind.attrs.get("trace_source") != "real"
    words = "S4 at noise level" if fig_no == 3 else "moderate S4"
    return Verdict(_agreement(surrogate, holds),
                   f"{_data_words(surrogate)}: S4 {np.nanmin(s4):.2f}-{np.nanmax(s4):.2f}, Phi60 {np.nanmin(phi):.2f}-{np.nanmax(phi):.2f} rad "
                   f"(noise-free, 60-s windows); chapter: {words}, high Phi60 (no number given)")


def _fig03_verdict(indices):
    return indices_verdict(indices, 3)


def _fig06_verdict(indices):
    return indices_verdict(indices, 6)


@figure("susi_fig03", "fig03_indices_high_latitude", paper=PAPER, section=SECTION, inputs=_indices_inputs(HIGH), surrogate=_surrogate(HIGH),
        number="Fig. 3", claim="high-latitude test signal: S4 stays at noise level while Phi60 is very high (an extreme phase-only event)",
        tables=(), verdict=_fig03_verdict)
def susi_fig03(indices):
    return indices_figure(indices, 3)


@figure("susi_fig06", "fig06_indices_equatorial", paper=PAPER, section=SECTION, inputs=_indices_inputs(EQUATORIAL),
        surrogate=_surrogate(EQUATORIAL), number="Fig. 6",
        claim="equatorial (Hanoi) event: moderate amplitude scintillation with high phase scintillation", tables=(), verdict=_fig06_verdict)
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


def _example_index(res: xr.Dataset) -> int:
    """Position of the example trial on the ``trial`` axis (0 when it is not there)."""
    trials = np.asarray(res["trial"].values)
    hit = np.flatnonzero(trials == int(res["example_trial"]))
    return int(hit[0]) if hit.size else 0


def discriminator_stats(res: xr.Dataset) -> dict[str, dict[str, float]]:
    """Per tracker: the 1-ms std of the example trial and over all trials (mean of the 60-s-window stds
    after the transient, the chapter's jitter) and the std of the drawn 10-ms means over the same span."""
    keep = steady_windows(res)
    w = np.asarray(res["window"].values, dtype=float)
    start = float(w[keep][0] - window_length_s(res) / 2)
    t = res["time"].values
    k = _example_index(res)
    out = {}
    for tr in jitter_trackers(res):
        jd = res["jitter_discriminator"].sel(tracker=tr).values
        drawn = res["example_discriminator"].sel(tracker=tr).values[t >= start]
        out[tr] = {"one_ms_trial": float(np.nanmean(jd[k, keep])), "one_ms_all": float(np.mean(trial_jitter(res, tr))),
                   "block_trial": float(np.nanstd(drawn)), "start": start}
    return out


def discriminator_figure(res: xr.Dataset, fig_no: int):
    trackers = jitter_trackers(res)
    stats = discriminator_stats(res)
    t = res["time"].values
    ss = _steady_start(res)
    n_tr = int(res["n_trials"])
    fig, axes = new_figure(len(trackers) + 1, 1, figsize=(7.2, 1.6 * len(trackers) + 3.0))
    data = {tr: res["example_discriminator"].sel(tracker=tr).values for tr in trackers}
    lim = 1.05 * max(float(np.nanmax(np.abs(v))) for v in data.values())
    for k, (ax, tr) in enumerate(zip(axes, trackers)):
        s = stats[tr]
        ax.plot(t, data[tr], lw=0.4, color=_colour(tr, k), label=_label(res, tr))
        ax.set_ylim(-lim, lim)
        ax.set_ylabel("phase error [rad]", fontsize=8)
        ax.set_title(f"{_label(res, tr)}: std of the 1-ms output {s['one_ms_trial']:.3f} rad ({s['one_ms_all']:.3f} over {n_tr} trials); "
                     f"of the {_block_ms(res)}-ms means drawn {s['block_trial']:.3f} rad", fontsize=7.5)
        ax.axvline(ss, color="0.4", lw=0.8, ls=":", label=f"end of the {ss:g}-s acquisition transient")
        ax.set_xlabel("time [s]", fontsize=8)
    length = min(5.0, float(t[-1] - t[0]) / 10)
    lo, hi = _zoom_span(t, data[trackers[0]], ss, length)
    zoom = axes[-1]
    keep = (t >= lo) & (t <= hi)
    for k, tr in enumerate(trackers):
        zoom.plot(t[keep], data[tr][keep], lw=0.9, color=_colour(tr, k), label=_label(res, tr))
        axes[k].axvspan(lo, hi, color="0.8", zorder=0, label="zoomed span (bottom panel)")
    zoom.set_xlabel("time [s]", fontsize=8)
    zoom.set_ylabel("phase error [rad]", fontsize=8)
    zoom.set_title(f"zoom on the largest {_label(res, trackers[0])} excursion after {ss:g} s ({_block_ms(res)}-ms means)", fontsize=8)
    fig.suptitle(f"Fig. {fig_no}: discriminator output (phase error), {_where(res)} scenario, trial {int(res['example_trial'])}\n"
                 f"{_block_ms(res)}-ms means of the {ts_ms(res)}-ms output; {_cond(res)}\n{source_text(res)}", fontsize=9)
    fig.tight_layout()
    ratio = ", ".join(f"{_plain(res, tr)} {stats[tr]['one_ms_trial'] / stats[tr]['block_trial']:.1f}" for tr in trackers
                      if stats[tr]["block_trial"] > 0)
    rank_1 = " < ".join(_plain(res, tr) for tr in sorted(trackers, key=lambda tr: stats[tr]["one_ms_all"]))
    rank_10 = " < ".join(_plain(res, tr) for tr in sorted(trackers, key=lambda tr: stats[tr]["block_trial"]))
    block = _block_ms(res)
    caption(fig, f"The chapter's measure is the std of the {ts_ms(res)}-ms discriminator output (its Fig. 5 jitter; here the mean of "
                  f"the {window_length_s(res):g}-s-window stds from {stats[trackers[0]]['start']:g} s on). It ranks {rank_1}. The panels "
                  f"draw {block}-ms means (what the results keep), whose std ranks {rank_10}: a {block}-ms mean divides white noise by "
                  f"sqrt({float(block) / float(ts_ms(res)):g}) = {math.sqrt(float(block) / float(ts_ms(res))):.1f} but keeps slow errors, so "
                  f"it favours the loop whose error is whitest, i.e. the widest loop. Ratio of the two stds: {ratio} "
                  f"({math.sqrt(float(block) / float(ts_ms(res))):.1f} for white noise; less: slow errors; more: errors that alternate in "
                  f"sign within {block} ms).")
    figure_legend(fig, *handles_of(axes[0], zoom), ncol=3, fontsize=7.5)
    return fig


def _result_inputs(scenario: str):
    return lambda c: {"result": paths.exp_result(CHAPTER, scenario)}


def discriminator_verdict(result: xr.Dataset) -> Verdict:
    """The chapter's Fig. 4 claim: the SAKF PLL has the least noisy discriminator output.

    Measured by the mean over trials of the 1-ms discriminator jitter (the chapter's metric,
    ``susi_table_jitter``).  Holds when the SAKF's is the lowest; status by :func:`_agreement`.
    """
    trackers = jitter_trackers(result)
    jit = {tr: float(np.mean(trial_jitter(result, tr))) for tr in trackers}
    holds = SAKF in jit and min(jit, key=jit.get) == SAKF
    surrogate = _surrogate_data(result)
    values = ", ".join(f"{_plain(result, tr)} {v:.3f}" for tr, v in jit.items())
    return Verdict(_agreement(surrogate, holds),
                   f"{_data_words(surrogate)}: 1-ms discriminator std {values} rad (mean over {int(result['n_trials'])} trials); "
                   f"SAKF {'is' if holds else 'is not'} the lowest (chapter: SAKF least noisy, no number given)")


@figure("susi_fig04", "fig04_discriminator_high_latitude", paper=PAPER, section=SECTION, inputs=_result_inputs(HIGH), surrogate=_surrogate(HIGH),
        number="Fig. 4", claim="of the three loops the SAKF PLL shows the least noisy discriminator output under high-latitude scintillation",
        tables=("susi_table_jitter",), verdict=discriminator_verdict)
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
    widest = 0.0
    for ax, (metric, var) in zip(axes, METRICS.items()):
        top = 0.0
        for k, tr in enumerate(trackers):
            m, lo, hi = mean_with_ci(res[var].sel(tracker=tr).values, axis=0)
            widest = max(widest, float(np.nanmax(hi - m)))
            top = max(top, float(np.nanmax(hi)))
            dx = (k - (len(trackers) - 1) / 2) * 0.02 * length
            ax.errorbar(w + dx, m, yerr=[m - lo, hi - m], fmt="o-", ms=4, lw=1.0, capsize=3, color=_colour(tr, k), label=_label(res, tr))
        if first > w[0] - length / 2:
            ax.axvspan(w[0] - length / 2, first, color="0.9", zorder=0, label="window with the acquisition transient (not in the tables)")
        ax.set_ylim(0, 1.15 * top)
        ax.set_ylabel("jitter [rad]")
        ax.set_xlabel(f"time [s] (centre of the {length:g}-s window)")
        ax.set_title(titles[metric], fontsize=9)
    _show_x_ticks(axes)
    fig.suptitle(f"Fig. {fig_no}: phase jitter per {length:g}-s window, {_where(res)} scenario\n"
                 f"mean over {int(res['n_trials'])} trials (error bars: 95% interval, at most $\\pm${widest:.4f} rad, narrower than the "
                 f"markers)\n{_cond(res)}\n{source_text(res)}", fontsize=8.5)
    fig.tight_layout()
    figure_legend(fig, *handles_of(*axes), ncol=2, fontsize=7.5)
    return fig


#: the chapter's claim per jitter figure: the claims of ``susi_table_claims`` it shows
JITTER_CLAIMS = {5: ("both KF PLLs have lower jitter than the PLL",),
                 8: ("both KF PLLs have lower jitter than the PLL", "SAKF has the lowest jitter")}


def jitter_verdict(result: xr.Dataset, fig_no: int) -> Verdict:
    """The chapter's claims for its Fig. 5 (KF PLLs below the PLL) and Fig. 8 (that, and the SAKF lowest).

    Each claim is tested as ``susi_table_claims`` tests it: paired per-trial differences of the
    discriminator jitter (the chapter's metric); it holds when every paired 95% interval lies below 0.
    Status by :func:`_agreement` (all of the figure's claims must hold).
    """
    labels = tracker_labels(result)
    results, holds_all = [], True
    for claim in JITTER_CLAIMS[fig_no]:
        ivs = [paired(trial_jitter(result, a), trial_jitter(result, b)) if has_jitter(result, a) and has_jitter(result, b)
               else (np.nan,) * 3 for a, b in CLAIMS[claim]]
        v = claim_verdict(ivs)
        holds_all &= v == "holds"
        results.append(f"'{claim}' {v}")
    jit = ", ".join(f"{labels.get(tr, tr)} {np.mean(trial_jitter(result, tr)):.3f}" for tr in jitter_trackers(result))
    surrogate = _surrogate_data(result)
    return Verdict(_agreement(surrogate, holds_all),
                   f"{_data_words(surrogate)}: discriminator jitter {jit} rad (mean over {int(result['n_trials'])} trials); "
                   f"{'; '.join(results)} (chapter: holds, no number given)")


def _fig05_verdict(result):
    return jitter_verdict(result, 5)


def _fig08_verdict(result):
    return jitter_verdict(result, 8)


@figure("susi_fig05", "fig05_jitter_high_latitude", paper=PAPER, section=SECTION, inputs=_result_inputs(HIGH), surrogate=_surrogate(HIGH),
        number="Fig. 5", claim="over 60-s windows both KF PLLs have a lower phase jitter than the 15-Hz PLL (high latitude)",
        tables=("susi_table_jitter", "susi_table_claims"), verdict=_fig05_verdict)
def susi_fig05(result):
    return jitter_figure(result, 5)


@figure("susi_fig08", "fig08_jitter_equatorial", paper=PAPER, section=SECTION, inputs=_result_inputs(EQUATORIAL), surrogate=_surrogate(EQUATORIAL),
        number="Fig. 8", claim="on the equatorial event the KF PLLs again have less jitter than the PLL, the SAKF PLL the least",
        tables=("susi_table_jitter", "susi_table_claims"), verdict=_fig08_verdict)
def susi_fig08(result):
    return jitter_figure(result, 8)


@figure("susi_fig05_event", "fig05_jitter_high_latitude_event", paper=PAPER, section=SECTION, inputs=_result_inputs(EVENT),
        surrogate=_surrogate(EVENT), number="Fig. 5",
        claim="over 60-s windows both KF PLLs have a lower phase jitter than the 15-Hz PLL (high latitude; here the real-index event)",
        tables=("susi_table_jitter", "susi_table_claims"), verdict=_fig05_verdict)
def susi_fig05_event(result):
    return jitter_figure(result, 5)


@figure("susi_fig05_event_T", "fig05_jitter_high_latitude_event_T", paper=PAPER, section=SECTION, inputs=_result_inputs(EVENT_T),
        surrogate=_surrogate(EVENT_T), number="Fig. 5",
        claim="over 60-s windows both KF PLLs have a lower phase jitter than the 15-Hz PLL (high latitude; here the real-index event, Ts1 as given)",
        tables=("susi_table_jitter", "susi_table_claims"), verdict=_fig05_verdict)
def susi_fig05_event_t(result):
    return jitter_figure(result, 5)


def _event_trace_inputs(config):
    return {"trace": paths.scenario_trace_path(config, EVENT), "trace_T": paths.scenario_trace_path(config, EVENT_T)}


def event_trace_verdict(trace: xr.Dataset, trace_T: xr.Dataset) -> Verdict:
    """No paper figure: the event and how far each trace's per-minute sigma_phi lies from the real Phi60 (median ratio)."""
    parts = [f"{ds.attrs['strength']}: trace/real sigma_phi median {np.nanmedian(ds['trace_phi60'].values / ds['real_phi60'].values):.2f}"
             for ds in (trace, trace_T)]
    return Verdict("no paper figure", f"{trace.attrs['real_event']}, median real Phi60 {float(trace.attrs['real_median_phi60']):.2f} rad; "
                                      + "; ".join(parts))


@figure("susi_event_trace", "event_trace_real_indices", paper=PAPER, section=SECTION, inputs=_event_trace_inputs,
        surrogate=lambda config: True, number=None,
        claim="the high-latitude scenario's strength taken from a real event (the pre-declared 20-minute run)",
        tables=("susi_table_jitter",), verdict=event_trace_verdict)
def susi_event_trace(trace: xr.Dataset, trace_T: xr.Dataset):
    """Per minute of the real event: the real Phi60 and the traces' sigma_phi (top), the real Ts1 and the T of each trace (bottom)."""
    fig, axes = new_figure(2, 1, figsize=(6.6, 6.0), sharex=True)
    minute = np.asarray(trace["minute"].values, dtype=float) + 0.5
    ax = axes[0]
    ax.plot(minute, trace["real_phi60"].values, "ks-", ms=4, lw=1.0, label=r"REAL $\Phi_{60}$ (receiver, Phi60s1)")
    ax.plot(minute, trace["trace_phi60"].values, "o-", color="C2", ms=4, lw=1.0, label=r"trace, strength from $\Phi_{60}$: $\sigma_\phi$ per minute")
    ax.plot(minute, trace_T["trace_phi60"].values, "^-", color="C3", ms=4, lw=1.0, label=r"trace, $T$ as given: $\sigma_\phi$ per minute")
    ax.set_yscale("log")
    log_ticks(ax)
    ax.set_ylabel(r"$\sigma_\phi$ over the minute [rad]")
    ax.set_title(r"phase scintillation per minute (0.1-Hz high-pass, 60 s)", fontsize=9)
    ax = axes[1]
    ax.plot(minute, trace["real_T"].values, "ks-", ms=4, lw=1.0, label="REAL $T$ (Ts1) = the trace's with $T$ as given")
    ax.plot(minute, trace["trace_T"].values, "o-", color="C2", ms=4, lw=1.0, label=r"$T$ of the trace with strength from $\Phi_{60}$")
    ax.set_yscale("log")
    log_ticks(ax)
    ax.set_ylabel("$T$: phase PSD at 1 Hz [rad$^2$/Hz]")
    ax.set_xlabel(f"minute of the event (from {trace.attrs['real_start_utc']} UTC)")
    ax.set_title("strength of the phase spectrum $T f^{-p}$ (each minute's real slope $p$ in both traces)", fontsize=9)
    ax.set_xticks(np.arange(0, minute.size + 1, 2))
    _show_x_ticks(axes)
    fig.suptitle(f"SURROGATE traces driven by REAL indices: {trace.attrs['real_event']}\n"
                 f"the 20-minute run with the largest median $\\Phi_{{60}}$ ({float(trace.attrs['real_median_phi60']):.2f} rad), every minute "
                 f">= {min(trace['real_cn0'].values):.0f} dB-Hz", fontsize=8.5)
    fig.tight_layout()
    caption(fig, "The real Ts1 does not integrate to the real Phi60 (a one-sided rad^2/Hz spectrum T f^-p above 0.1 Hz gives 2-10 rad): "
                 "the trace the verdict is read on keeps the real slope p and takes its strength from Phi60.")
    figure_legend(fig, *handles_of(*axes), ncol=2, fontsize=7.5)
    return fig


# --- Fig. 7: carrier Doppler --------------------------------------------------------------------


TRUTH_SMOOTH_S = 0.1  # the true Doppler averaged over 0.1 s (the clock's white FM is not trackable)
RMS_BLOCK_S = 5.0  # block of the RMS error panel
JUMP_S = 0.2  # lag of the step search (two refreshes of the SAKF's scintillation block)
STEP_TRUTH_SHARE = 0.3  # a step of the estimate counts as its own when the truth moves by less than this share of it


def _smooth_truth(res: xr.Dataset) -> np.ndarray:
    from scipy.ndimage import uniform_filter1d

    t = res["time"].values
    truth = res["example_frequency_true"].values
    return uniform_filter1d(truth, size=max(int(round(TRUTH_SMOOTH_S / (t[1] - t[0]))), 1), mode="nearest")


def _doppler_trackers(res: xr.Dataset) -> list[str]:
    return [str(tr) for tr in res["tracker"].values if np.isfinite(res["example_frequency"].sel(tracker=tr).values).any()]


def doppler_rms(res: xr.Dataset) -> dict[str, float]:
    """RMS of estimate minus the 0.1-s mean of the true Doppler after the transient, example trial."""
    t = res["time"].values
    after = t >= _steady_start(res)
    smooth = _smooth_truth(res)
    return {tr: float(np.sqrt(np.nanmean((res["example_frequency"].sel(tracker=tr).values - smooth)[after] ** 2))) for tr in _doppler_trackers(res)}


def largest_step(t: np.ndarray, estimate: np.ndarray, truth: np.ndarray, start: float, lag_s: float = JUMP_S,
                 share: float = STEP_TRUTH_SHARE) -> tuple[float, float]:
    """(time, size) of the largest change of ``estimate`` over ``lag_s`` after ``start`` while ``truth``
    changes by less than ``share`` of it: a step the loop makes by itself, not one it follows (time: the
    middle of the lag; NaN when there is none)."""
    lag = max(int(round(lag_s / (t[1] - t[0]))), 1)
    d_est = estimate[lag:] - estimate[:-lag]
    d_true = truth[lag:] - truth[:-lag]
    mid = 0.5 * (t[lag:] + t[:-lag])
    ok = (mid >= start) & np.isfinite(d_est) & np.isfinite(d_true) & (np.abs(d_true) < share * np.abs(d_est))
    if not ok.any():
        return float("nan"), float("nan")
    k = np.flatnonzero(ok)[int(np.argmax(np.abs(d_est[ok])))]
    return float(mid[k]), float(d_est[k])


def doppler_figure(res: xr.Dataset, fig_no: int):
    fig, axes = new_figure(2, 1, figsize=(6.8, 6.4))
    t = res["time"].values
    ss = _steady_start(res)
    smooth = _smooth_truth(res)
    line = float(res.attrs["fd0_hz"]) + float(res.attrs["fr_hz_s"]) * t
    trackers = _doppler_trackers(res)
    rms = doppler_rms(res)
    length = min(10.0, float(t[-1] - t[0]) / 10)
    jump_t, jump = (largest_step(t, res["example_frequency"].sel(tracker=SAKF).values, smooth, ss) if SAKF in trackers
                    else (float("nan"), float("nan")))
    centre = jump_t if np.isfinite(jump_t) else ss + length / 2
    lo = min(max(centre - length / 2, ss), float(t[-1]) - length)
    keep = (t >= lo) & (t <= lo + length)
    zoom, err = axes
    zoom.plot(t[keep], (smooth - line)[keep], lw=1.8, color="0.1", label=f"truth ({TRUTH_SMOOTH_S:g}-s mean)")
    nb = max(int(round(RMS_BLOCK_S / (t[1] - t[0]))), 1)
    nblk = t.size // nb
    tb = t[: nblk * nb].reshape(nblk, nb).mean(axis=1)
    for k, tr in enumerate(trackers):
        f = res["example_frequency"].sel(tracker=tr).values
        c = _colour(tr, k)
        zoom.plot(t[keep], (f - line)[keep], lw=1.0, color=c, label=f"{_label(res, tr)}: RMS error after {ss:g} s = {rms[tr]:.3f} Hz")
        e2 = ((f - smooth)[: nblk * nb] ** 2).reshape(nblk, nb)
        err.plot(tb, np.sqrt(np.nanmean(e2, axis=1)), lw=1.2, marker="o", ms=2.5, color=c)
    if np.isfinite(jump_t):
        zoom.axvline(jump_t, color=_colour(SAKF, 2), lw=0.8, ls=":", label=f"largest {JUMP_S:g}-s step of the SAKF estimate with a still truth ({jump:+.2f} Hz)")
    zoom.set_xlim(lo, lo + length)
    zoom.set_ylabel("Doppler $-$ ($f_{d0} + f_r t$) [Hz]", fontsize=8)
    zoom.set_xlabel("time [s]")
    zoom.set_title(f"{length:g}-s zoom; line-of-sight dynamics $f_{{d0}}$ = {float(res.attrs['fd0_hz']):g} Hz, "
                   f"$f_r$ = {float(res.attrs['fr_hz_s']):g} Hz/s removed", fontsize=8)
    err.axvspan(lo, lo + length, color="0.85", zorder=0, label="zoomed span (top panel)")
    err.axvline(ss, color="0.4", lw=0.8, ls=":", label=f"end of the {ss:g}-s acquisition transient")
    err.set_ylim(bottom=0)
    err.set_ylabel(f"RMS of estimate $-$ truth\nper {RMS_BLOCK_S:g} s [Hz]", fontsize=8)
    err.set_xlabel("time [s]")
    err.set_title(f"Doppler error over the whole run (truth: {TRUTH_SMOOTH_S:g}-s mean)", fontsize=8)
    fig.suptitle(f"Fig. {fig_no}: carrier Doppler estimates, {_where(res)} scenario, trial {int(res['example_trial'])}\n"
                 f"{_block_ms(res)}-ms means; truth = dynamics + clock + scintillation; {_cond(res)}\n{source_text(res)}", fontsize=9)
    fig.tight_layout()
    if SAKF in trackers:
        caption(fig, "SAKF flat stretches and steps: while its 3-s power-law fit is steep (p of about 4 or more), eq. (7) "
                      "S = T f$^{-p}$, taken from the 0.5-5 Hz fit band down to f = 0.19 Hz, puts a very large process noise on the "
                      "phase state. The filter then explains the scintillation with its phase state and its Doppler keeps only the "
                      "ramp (a plateau); when a 0.1-s refresh lowers T and p, the Doppler state catches up at once (a step"
                      + (f", largest here {jump:+.2f} Hz in {JUMP_S:g} s at {jump_t:.1f} s, dotted line)." if np.isfinite(jump_t) else ")."))
    figure_legend(fig, *handles_of(zoom, err), ncol=2, fontsize=7.5)
    return fig


def doppler_verdict(result: xr.Dataset) -> Verdict:
    """The chapter's Fig. 7 claim: the KF PLLs' Doppler is less noisy than the PLL's, the SAKF's least.

    Measured by the RMS of estimate minus the 0.1-s mean of the true Doppler after the transient, in
    the example trial (the only one whose Doppler is stored).  Holds when both KF PLLs are below the
    PLL and the SAKF is the lowest; status by :func:`_agreement`.
    """
    rms = doppler_rms(result)
    holds = (all(k in rms for k in (REFERENCE, AKF, SAKF)) and rms[AKF] < rms[REFERENCE] and rms[SAKF] < rms[REFERENCE]
             and rms[SAKF] < rms[AKF])
    surrogate = _surrogate_data(result)
    values = ", ".join(f"{_plain(result, tr)} {v:.3f}" for tr, v in rms.items())
    return Verdict(_agreement(surrogate, holds),
                   f"{_data_words(surrogate)}: Doppler RMS error {values} Hz (trial {int(result['example_trial'])}, after "
                   f"{_steady_start(result):g} s); chapter: KF PLLs less noisy, SAKF best (no number given)")


@figure("susi_fig07", "fig07_doppler_equatorial", paper=PAPER, section=SECTION, inputs=_result_inputs(EQUATORIAL), surrogate=_surrogate(EQUATORIAL),
        number="Fig. 7", claim="the KF PLLs give a less noisy carrier Doppler than the PLL on the equatorial event, the SAKF PLL the least noisy",
        tables=(), verdict=doppler_verdict)
def susi_fig07(result):
    return doppler_figure(result, 7)


# --- SAKF monitor ------------------------------------------------------------------------------


def _monitor_inputs(config):
    out = {}
    for sc in experiment_scenarios(config, CHAPTER):
        out[f"result_{sc}"] = paths.exp_result(CHAPTER, sc)
        out[f"indices_{sc}"] = paths.susi_indices_path(sc)
        trace = paths.scenario_trace_path(config, sc)
        if trace is not None:
            out[f"trace_{sc}"] = trace
    return out


def _monitor_kwargs(config):
    """Where each trace scenario's tracked part lies in its trace file, and the SAKF's window and fit band."""
    spans = []
    for sc in experiment_scenarios(config, CHAPTER):
        spec = config["scenarios"][sc]
        if "trace" in spec:
            spans.append([sc, float(spec["trace"].get("fit_s", 0.0)), float(spec["duration_s"]), float(spec.get("ts", config["sampling"]["ts"]))])
    sakf = config.get("trackers", {}).get(SAKF, {})
    return {"trace_spans": spans, "sakf_window_s": float(sakf.get("window_s", 3.0)),
            "sakf_fit_band_hz": [float(v) for v in sakf.get("fit_band_hz", (0.5, 5.0))]}


def _monitor_surrogate(config) -> bool:
    return any(scenario_is_surrogate(config, sc) for sc in experiment_scenarios(config, CHAPTER))


def _monitored(res: xr.Dataset) -> list[str]:
    return [str(tr) for tr in res["tracker"].values if "phi3_mean" in res and np.isfinite(res["phi3_mean"].sel(tracker=tr).values).any()]


def _split(datasets, trace_spans):
    """(results, {scenario: indices}, {scenario: trace}) from the positional inputs (traces in ``trace_spans`` order)."""
    results = [d for d in datasets if "tracker" in d.dims]
    indices = {d.attrs["scenario"]: d for d in datasets if "tracker" not in d.dims and "phi3_true" in d}
    traces = [d for d in datasets if "phase" in d and "band" in d.dims]
    named = {}
    for span, ds in zip(trace_spans or [], traces):
        named[str(span[0])] = (ds, span)
    return results, indices, named


def sakf_way_truth(trace: xr.Dataset, span, window_s: float, fit_band_hz, step_s: float = 0.5) -> dict[str, np.ndarray]:
    """Phi3, T and p of the noise-free scintillation phase computed as the SAKF computes its own:
    windows of ``window_s`` ending every ``step_s``, each detrended by a least-squares quadratic
    (:func:`scintrack.trackers.susi_kf.quadratic_detrend`), std and power-law fit over ``fit_band_hz``."""
    from ...data.susi_traces import at_rate
    from ...estimators.power_law import estimate_power_law
    from ...trackers.susi_kf import quadratic_detrend

    _, fit_s, duration_s, ts = span
    _, theta, _ = at_rate(trace, float(ts))
    i0, n = int(round(float(fit_s) / ts)), int(round(float(duration_s) / ts))
    th = theta[i0 : i0 + n]
    th = th - th[0]
    w, step = int(round(window_s / ts)), max(int(round(step_s / ts)), 1)
    starts = np.arange(0, th.size - w + 1, step)
    resid, phi3 = quadratic_detrend(th[starts[:, None] + np.arange(w)[None, :]])
    _, T, p = estimate_power_law(resid, ts, window_s=w * ts, f_lo_hz=float(fit_band_hz[0]), f_hi_hz=float(fit_band_hz[1]))
    return {"time": (starts + w) * ts, "phi3": phi3, "T": T[:, 0], "p": p[:, 0]}


def monitor_stats(datasets, trace_spans=None, sakf_window_s: float = 3.0, sakf_fit_band_hz=(0.5, 5.0)) -> list[dict]:
    """Per scenario: mean on-line Phi3 (after the transient), and the noise-free Phi3 the SAKF's way and the ISMR way."""
    results, indices, traces = _split(datasets, trace_spans)
    out = []
    for res in results:
        sc = str(res.attrs["scenario"])
        t = res["time"].values
        after = t >= _steady_start(res)
        row = {"scenario": sc, "where": _where(res), "surrogate": _surrogate_data(res), "online": np.nan, "sakf_way": np.nan, "ismr": np.nan}
        if SAKF in _monitored(res):
            row["online"] = float(np.nanmean(res["phi3_mean"].sel(tracker=SAKF).values[after]))
        if sc in traces:
            truth = sakf_way_truth(*traces[sc], sakf_window_s, sakf_fit_band_hz)
            row["sakf_way"] = float(np.nanmean(truth["phi3"][truth["time"] >= _steady_start(res)]))
            row["truth"] = truth
        ind = indices.get(sc)
        if ind is not None:
            g = ind["grid"].values
            row["ismr"] = float(np.nanmean(ind["phi3_true"].values[g >= _steady_start(res)]))
        out.append(row)
    return out


def monitor_verdict(*datasets, trace_spans=None, sakf_window_s: float = 3.0, sakf_fit_band_hz=(0.5, 5.0)) -> Verdict:
    """The chapter has no figure of the SAKF's monitors: the verdict states the mean on-line Phi3 against
    the noise-free Phi3 computed the same way (and the ISMR way), per scenario."""
    stats = monitor_stats(datasets, trace_spans, sakf_window_s, sakf_fit_band_hz)
    parts = []
    for st in stats:
        if np.isfinite(st["online"]):
            parts.append(f"{st['where']} on-line Phi3 {st['online']:.2f} rad vs noise-free {st['sakf_way']:.2f} rad same detrending "
                         f"({st['ismr']:.2f} rad with the 0.1-Hz high-pass)")
    surrogate = any(st["surrogate"] for st in stats) if stats else True
    return Verdict("no paper figure", f"{_data_words(surrogate)}: " + ("; ".join(parts) if parts else "no SAKF monitor in the results"))


@figure("susi_sakf_monitor", "sakf_monitor", paper=PAPER, section=SECTION, inputs=_monitor_inputs, kwargs=_monitor_kwargs, surrogate=_monitor_surrogate,
        number=None, claim="the chapter feeds the SAKF with on-line Phi3, T and p from its own carrier phase (eqs. 7, 8, 12) but shows no plot of them",
        tables=("susi_table_alpha",), verdict=monitor_verdict)
def susi_sakf_monitor(*datasets, trace_spans=None, sakf_window_s: float = 3.0, sakf_fit_band_hz=(0.5, 5.0)):
    """Rows: Phi3, p, T, weight; columns: the scenarios (result, indices and trace inputs per scenario, in input order)."""
    stats = monitor_stats(datasets, trace_spans, sakf_window_s, sakf_fit_band_hz)
    results, indices, _ = _split(datasets, trace_spans)
    rows = (("phi3", r"$\Phi_3$ [rad]"), ("p", "slope $p$"), ("T", "strength $T$ [rad$^2$/Hz]"), ("weight", "gain weight $w$"))
    fig, axes = new_figure(len(rows), len(results), figsize=(4.2 * len(results) + 0.8, 8.6), sharex="col", squeeze=False)
    for j, (res, st) in enumerate(zip(results, stats)):
        ind = indices.get(res.attrs["scenario"])
        t = res["time"].values
        truth = st.get("truth")
        for i, (key, name) in enumerate(rows):
            ax = axes[i, j]
            if key == "phi3" and ind is not None:
                ax.plot(ind["grid"].values, ind["phi3_true"].values, lw=0.7, ls="--", color="0.6",
                        label=f"noise-free phase, ISMR way ({float(ind.attrs['phi3_window_s']):g}-s window, "
                              f"causal {float(ind.attrs.get('detrend_hz', 0.1)):g}-Hz high-pass)")
            stat = "mean over trials"
            if key == "T":  # a sharded result carries the first shard's median (experiments/merge.py)
                covered = int(res["T_mean"].attrs.get("median_trials", res["n_trials"]))
                stat = "median over trials" if covered == int(res["n_trials"]) else f"median over the first {covered} of {int(res['n_trials'])} trials"
            for k, tr in enumerate(_monitored(res)):
                ax.plot(t, res[f"{key}_mean"].sel(tracker=tr).values, lw=0.7, color=_colour(tr, 2 + k),
                        label=f"{_label(res, tr)} on-line, from its own carrier phase (mean over trials; T: median)")
            if truth is not None and key in truth:  # on top of the on-line line: the two nearly coincide
                ax.plot(truth["time"], truth[key], lw=0.6, color="black",
                        label=f"noise-free phase, the SAKF's way ({sakf_window_s:g}-s window, quadratic fit removed)")
            if key == "T":
                ax.text(0.01, 0.97, f"on-line T: {stat}", transform=ax.transAxes, fontsize=MIN_FONT_PT, va="top",
                        bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "none", "pad": 1.5})
                ax.set_yscale("log")
                log_ticks(ax)  # a narrow span (a short run) still gets labelled ticks
            if key == "weight":
                ax.set_ylim(0, 1.05)
            if j == 0:
                ax.set_ylabel(name)
            ax.set_xlabel("time [s]", fontsize=8)
            if i == 0:
                ax.set_title(f"{_where(res)}: {_cond(res)}\n{int(res['n_trials'])} trials ({source_text(res).split(',')[0]})", fontsize=8)
    _show_x_ticks(axes)
    fig.suptitle("SAKF PLL: on-line scintillation parameters (eqs. 7, 8)\nand the eq. (12) gain weight $w = \\alpha(1 + \\Phi_3/\\phi_{ref})^{-\\gamma}$",
                 fontsize=9)
    fig.tight_layout()
    parts = []
    for st in stats:
        if np.isfinite(st["online"]) and np.isfinite(st["sakf_way"]):
            part = (f"{st['where']}: on-line {st['online']:.2f} rad vs {st['sakf_way']:.2f} rad noise-free with the same detrending")
            if np.isfinite(st["ismr"]):
                part += f" ({st['ismr']:.2f} rad with the 0.1-Hz high-pass, {st['ismr'] / st['sakf_way']:.1f} times more)"
            parts.append(part)
        elif np.isfinite(st["online"]) and np.isfinite(st["ismr"]):
            parts.append(f"{st['where']}: on-line {st['online']:.2f} rad (quadratic fit over 3 s) vs {st['ismr']:.2f} rad noise-free with the "
                         "0.1-Hz high-pass; the detrendings differ")
    if parts:
        caption(fig, "Mean $\\Phi_3$ after the transient: " + "; ".join(parts) + ". The SAKF removes a quadratic fit from each 3-s window, "
                      "which also removes the 0.1-0.3 Hz part of the phase that dominates a steep power law; the ISMR convention keeps it.")
    figure_legend(fig, *handles_of(*axes[:, 0]), ncol=1, fontsize=7.5)
    return fig


# --- the REAL Septentrio indices beside the SURROGATE scenarios ----------------------------------

#: index -> (symbol, unit in the title, axis label, log x axis) of the panels
REAL_AXES = {"phi60": (r"$\Phi_{60}$", " rad", r"$\Phi_{60}$ [rad]", True),
             "s4": ("$S_4$", "", "$S_4$ (thermal-noise part removed) [no unit]", False),
             "T": ("$T$", " rad$^2$/Hz", "$T$: phase PSD at 1 Hz [rad$^2$/Hz]", True),
             "p": ("$p$", "", "$p$: slope of the phase PSD $T f^{-p}$ [no unit]", False)}
STATION_COLOURS = ("C0", "C1", "C4", "C5")
SCENARIO_COLOURS = ("C2", "C3", "C6", "C8", "C9")


def exceedance(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sorted values and the fraction of values at or above each (1 down to 1/n): the empirical survival function."""
    x = np.sort(np.asarray(values, dtype=float))
    return x, (x.size - np.arange(x.size)) / max(x.size, 1)


def event_neighbours(biscef: xr.Dataset) -> list[float]:
    """Phi60 of the chosen event's satellite in the minutes before and after it (those at the elevation mask)."""
    ev = real_event(biscef)
    same = (np.asarray(biscef["station"].values).astype(str) == str(ev["station"])) & (np.asarray(biscef["prn"].values) == int(ev["prn"]))
    t = np.asarray(biscef["time"].values).astype("datetime64[s]")
    t0 = np.datetime64(str(ev["time_utc"]), "s")
    near = same & (np.abs((t - t0).astype(np.int64)) == 60)
    return [float(v) for v in np.asarray(biscef["phi60"].values, dtype=float)[near]]


def real_share_above(biscef: xr.Dataset, var: str, level: float) -> tuple[int, int]:
    """(minutes with ``var`` >= ``level``, minutes with a value) over every station."""
    v = np.asarray(biscef[var].values, dtype=float)
    v = v[np.isfinite(v)]
    return int((v >= level).sum()), int(v.size)


def real_indices_verdict(biscef: xr.Dataset, *indices: xr.Dataset) -> Verdict:
    """No paper figure: the chapter's scenario has no index record to compare with.  The line gives the real
    Phi60 99th percentile per station, the chosen event, and how many real minutes reach the smallest
    per-window Phi60 of each scenario."""
    ev = real_event(biscef)
    p99 = ", ".join(f"{name} {np.percentile(station_values(biscef, code, 'phi60'), 99):.2f} rad" for code, name in real_stations(biscef))
    reach = []
    for ind in indices:
        low = float(np.nanmin(scenario_minutes(ind)["phi60"]))
        k, n = real_share_above(biscef, "phi60", low)
        reach.append(f"{scenario_name(ind)} Phi60 >= {low:.2f} rad in {k} of {n} real minutes")
    return Verdict("no paper figure", f"real Phi60 99th percentile {p99}; max {float(ev['phi60']):.2f} rad ({ev['station_name']} PRN "
                                      f"{int(ev['prn'])} {ev['time_utc']} UTC, the chosen event); " + "; ".join(reach))


@figure("susi_real_indices", "real_indices_vs_surrogate_scenarios", paper=PAPER, section=SECTION, inputs=real_indices_inputs,
        surrogate=lambda config: False, number=None,
        claim="the chapter's high-latitude test signal is an extreme phase-only event (S4 at noise level, very high Phi60); "
              "real high-latitude indices show how extreme",
        tables=("susi_table_real_indices",), verdict=real_indices_verdict)
def susi_real_indices(biscef: xr.Dataset, *indices: xr.Dataset):
    """Exceedance curves of the real Phi60, S4, T and p per station, the scenarios' per-window values and the chosen event."""
    ev = real_event(biscef)
    fig, axes = new_figure(2, 2, figsize=(7.6, 6.6))
    mask = float(biscef.attrs["elevation_min_deg"])
    windows = sorted({float(ind.attrs["window_s"]) for ind in indices})
    minutes = [scenario_minutes(ind) for ind in indices]
    for ax, (var, _label, _unit) in zip(axes.ravel(), REAL_INDICES):
        symbol, unit, xlabel, logx = REAL_AXES[var]
        lowest = 1.0
        for k, (code, name) in enumerate(real_stations(biscef)):
            v = station_values(biscef, code, var)
            if logx:
                v = v[v > 0]
            x, y = exceedance(v)
            lowest = min(lowest, float(y[-1])) if y.size else lowest
            ax.step(x, y, where="post", lw=1.2, color=STATION_COLOURS[k % len(STATION_COLOURS)],
                    label=f"{name} ({code}), real: GPS satellite-minutes at elevation $\\geq$ {mask:g}°")
        for k, (ind, vals) in enumerate(zip(indices, minutes)):
            colour = SCENARIO_COLOURS[k % len(SCENARIO_COLOURS)]
            v = vals[var][np.isfinite(vals[var])]
            if not v.size:
                continue
            ax.axvspan(float(v.min()), float(v.max()), color=colour, alpha=0.18, lw=0)
            ax.plot(v, np.full(v.size, 0.9 - 0.1 * k), ls="none", marker="v", ms=6, color=colour, transform=ax.get_xaxis_transform(),
                    label=f"{scenario_name(ind)}: value per {float(ind.attrs['window_s']):g}-s window (triangles) and their range (band)")
        ax.axvline(float(ev[var]), color="red", lw=1.0, ls="--",
                   label=f"chosen event: {ev['station_name']} GPS PRN {int(ev['prn'])}, {ev['time_utc'].replace('T', ' ')} UTC")
        ax.set_yscale("log")
        ax.set_ylim(0.5 * lowest, 1.6)
        if logx:
            ax.set_xscale("log")
            log_ticks(ax, "x")
        log_ticks(ax)
        ax.set_xlabel(xlabel, fontsize=8)
        ax.set_ylabel("fraction of minutes\nwith a value $\\geq x$", fontsize=8)
        ax.set_title(f"{symbol}: chosen event {float(ev[var]):.3g}{unit}", fontsize=8.5)
    fig.suptitle(f"Real Septentrio scintillation indices, Tromsø and Ny-Ålesund, 2023-01-15 (GPS L1 C/A, elevation $\\geq$ {mask:g}°),\n"
                 + textwrap.fill("beside the Susi 2014 scenarios: " + ", ".join(f"{scenario_name(ind)}" for ind in indices), 100), fontsize=9)
    fig.tight_layout()
    neighbours = event_neighbours(biscef)
    near = (f" The same satellite's $\\Phi_{{60}}$ in the minutes before and after: {', '.join(f'{v:.2f}' for v in neighbours)} rad."
            if neighbours else "")
    caption(fig, "Real: the receivers' one-minute indices of every GPS satellite (S4 with its thermal-noise part removed, 0 in most quiet "
                 "minutes; $\\Phi_{60}$ after a 0.1-Hz high-pass; T and p fitted by the receiver over 0.1-25 Hz). Scenarios: the noise-free "
                 "trace per " + "/".join(f"{w:g}" for w in windows) + "-s window (S4 of the detrended intensity, $\\Phi_{60}$ after a 0.1-Hz "
                 "high-pass; T and p the medians of 3-s fits over 0.5-5 Hz). Chosen event: the minute with the largest $\\Phi_{60}$ at "
                 f"elevation $\\geq$ {mask:g}° (rule fixed before any run): $\\Phi_{{60}}$ {float(ev['phi60']):.2f} rad, S4 {float(ev['s4']):.2f} "
                 f"(noise correction {float(ev['s4_correction']):.2f}), T {float(ev['T']):.3g} rad$^2$/Hz, p {float(ev['p']):.2f}, "
                 f"C/N$_0$ {float(ev['cn0']):.1f} dB-Hz, elevation {float(ev['elevation']):.1f}°." + near)
    figure_legend(fig, *handles_of(*axes.ravel()), ncol=1, fontsize=7.5)
    return fig


# --- in-band strength: jitter against the phase scale (pre-declared reading) ----------------------------------


def _inband_figure_inputs(config):
    from ..tables.susi_2014 import _inband_inputs

    return _inband_inputs(config)


def _inband_figure_surrogate(config) -> bool:
    from ..tables.susi_2014 import _inband_surrogate

    return _inband_surrogate(config)


def inband_verdict(*results) -> Verdict:
    """No chapter figure: the verdict per site and scale (the tracker with the lowest discriminator jitter, with paired intervals)."""
    from ..tables.susi_2014 import inband_results, lowest_verdict, phase_scale

    parts = []
    for s, group in inband_results(results).items():
        parts.append(f"{s.replace('_', ' ')}: " + "; ".join(f"x{phase_scale(r):g} {lowest_verdict(r)[1]}" for r in group))
    surrogate = any(_surrogate_data(r) for r in results)
    return Verdict("no paper figure", f"{_data_words(surrogate)}: " + " | ".join(parts))


#: short tracker names of the in-band figure's titles
SHORT = {"susi_pll": "PLL", "susi_akf": "AKF", "susi_sakf": "SAKF"}


def _lowest_short(res) -> str:
    """The lowest tracker's short name, ``A~B`` for a tie (a paired interval that includes 0)."""
    from ..tables.susi_2014 import INBAND_TRACKERS, lowest_verdict

    best, _ = lowest_verdict(res)
    ties = [t for t in INBAND_TRACKERS if t != best and has_jitter(res, t)
            and paired(trial_jitter(res, best), trial_jitter(res, t))[2] >= 0]
    return "~".join(SHORT.get(t, t) for t in [best, *ties])


@figure("susi_fig_inband", "fig_inband", paper=PAPER, section=SECTION, inputs=_inband_figure_inputs, surrogate=_inband_figure_surrogate,
        number=None, claim="the chapter's claim (KF PLLs, the SAKF first, below the PLL) at other strengths of the same scintillation phase",
        tables=("susi_table_inband",), verdict=inband_verdict)
def susi_fig_inband(*results):
    """Discriminator jitter (top) and its paired difference to the PLL (bottom) against the phase scale, per site."""
    from ..tables.susi_2014 import INBAND_TRACKERS, inband_results, phase_scale

    groups = inband_results(results)
    fig, axes = new_figure(2, len(groups), figsize=(4.6 * len(groups), 6.6), squeeze=False)
    widest = 0.0
    for col, (s, group) in enumerate(groups.items()):
        scales = np.array([phase_scale(r) for r in group])
        top, bottom = axes[0, col], axes[1, col]
        for k, tr in enumerate(INBAND_TRACKERS):
            stats = [mean_with_ci(trial_jitter(r, tr)) if has_jitter(r, tr) else (np.nan,) * 3 for r in group]
            m, lo, hi = (np.array(v, dtype=float) for v in zip(*stats))
            widest = max(widest, float(np.nanmax(hi - m)))
            dx = 1.0 + 0.02 * (k - 1)  # a small offset on the log axis so that the bars do not overlap
            top.errorbar(scales * dx, m, yerr=[m - lo, hi - m], fmt="o-", ms=4, lw=1.0, capsize=3, color=_colour(tr, k), label=_label(group[0], tr))
            if tr != REFERENCE:
                d = [paired(trial_jitter(r, tr), trial_jitter(r, REFERENCE)) if has_jitter(r, tr) else (np.nan,) * 3 for r in group]
                dm, dlo, dhi = (np.array(v, dtype=float) for v in zip(*d))
                bottom.errorbar(scales * dx, dm, yerr=[dm - dlo, dhi - dm], fmt="o-", ms=4, lw=1.0, capsize=3, color=_colour(tr, k),
                                label=_label(group[0], tr))
        bottom.axhline(0.0, color=_colour(REFERENCE, 0), lw=1.0, ls="--", label=f"{_label(group[0], REFERENCE)} (difference 0)")
        lowest = [_lowest_short(r) for r in group]
        for ax in (top, bottom):
            ax.set_xscale("log")
            ax.set_xticks(scales)
            ax.set_xticklabels([f"{v:g}" for v in scales])
            ax.minorticks_off()
            ax.set_xlabel("phase scale (x the trace's scintillation phase)")
        top.set_ylim(bottom=0)
        top.set_ylabel("discriminator jitter [rad]")
        bottom.set_ylabel("minus PLL, paired [rad]")
        where = "high latitude" if "high_latitude" in s else "equatorial" if "equatorial" in s else s
        top.set_title(f"{where}: {_cond(group[0])}\nlowest: " + ", ".join(f"x{v:g} {t}" for v, t in zip(scales, lowest)), fontsize=7.5)
        bottom.set_title(f"{where}: tracker minus PLL, same realisations", fontsize=8)
    first = results[0]
    fig.suptitle("Susi et al. 2014 on SYNTHETIC SURROGATE scintillation: jitter against the strength of the scintillation phase"
                 if any(_surrogate_data(r) for r in results) else
                 "Susi et al. 2014: jitter against the strength of the scintillation phase", fontsize=9)
    fig.tight_layout()
    caption(fig, f"Each point: mean over {int(first['n_trials'])} trials of the per-trial discriminator jitter (std over the "
                 f"{window_length_s(first):g}-s windows after {_steady_start(first):g} s); error bars: 95% intervals, at most "
                 f"$\\pm${widest:.4f} rad on the top row, narrower than the markers. The phase of the trace is scaled, its amplitude "
                 "is not; every scale sees the same noise realisations. 'lowest': the tracker with the lowest mean discriminator "
                 "jitter whose paired 95% interval to each other tracker lies below 0; 'A~B': A has the lower mean, the paired "
                 "interval to B includes 0.")
    figure_legend(fig, *handles_of(*axes.ravel()), ncol=2, fontsize=7.5)
    return fig
