"""Figures of Zhao, Khanafseh & Pervan (MM Kalman filter through wideband jamming): the dataset's figures.

The paper's Fig. 5 (clean signal) and Fig. 8 (jammed signal) show the
spectrum of the recorded IQ and the C/N0 over the run; here both come from
our SKYDEL-like dataset: the Welch spectrum of the IQ recording's clean and
jammed segments (``results/zhao_jamming/iq_spectrum.nc``), the spectrum of
the first satellite's prompt after code and Doppler wipe-off (the paper's
"sinc-shaped peak"), and the C/N0 estimated from correlator outputs by the
M2M4 estimator beside the truth (``results/zhao_jamming/cn0_estimates.nc``).
A sky plot of the scenario's satellites and a plot of one LNAV frame with its
fields marked document the dataset itself (no paper figure).  Every title
says the data are synthetic (``conventions.data_title``).

Choices a reader could question:

* The segments share one colour in every panel (clean blue, jammed red); the
  satellites' C/N0 traces use other colours, so no colour means two things.
  One legend below all panels names them (``conventions.figure_legend``).
* The C/N0 is 46 dB-Hz clean and about 15 dB-Hz jammed in the dataset by
  construction (the paper's values); the verdicts compare the ESTIMATE with the
  paper, which checks the estimator and the jammer power, not an independent
  measurement.
* The clean segment of Fig. 5 is the part of our jammed run before the onset
  (windows that end before it); the paper recorded a separate clean scenario.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ...pipeline import paths
from ..registry import Verdict, figure
from .common import new_figure
from .conventions import data_title, figure_legend, handles_of

if TYPE_CHECKING:
    import xarray as xr

PAPER = "zhao_jamming"
SEC_DATA = "Zhao et al.: jammed SKYDEL-like dataset"
SYNTHETIC = data_title("synthetic SKYDEL-like")
SEGMENT_COLORS = {"clean": "tab:blue", "jammed": "tab:red"}
PRN_COLORS = ("tab:green", "tab:purple", "tab:brown", "tab:olive", "tab:cyan", "tab:pink")
#: the paper's C/N0 (dB-Hz) of the clean and the jammed signal, and its jammer bandwidth (Hz)
PAPER_CN0 = {"clean": 46.0, "jammed": 15.0}
PAPER_JAMMER_BW_HZ = 8e6
#: how close (dB) the mean estimated C/N0 must be to the paper's for "reproduced"
CN0_TOLERANCE_DB = {"clean": 1.0, "jammed": 2.0}


def _spectrum_panel(ax, spectrum: xr.Dataset, segments: list[str]) -> None:
    for seg in segments:
        s = spectrum.sel(segment=seg)
        ax.plot(s["freq"].values / 1e6, s["psd_db"].values, color=SEGMENT_COLORS.get(seg), lw=0.8,
                label=f"{seg} segment (IQ from t = {float(s['start_s']):g} s)")
    ax.set_xlabel("frequency offset from L1 [MHz]")
    ax.set_ylabel("PSD [dB/Hz rel. full scale]")
    ax.set_xlim(float(spectrum["freq"].min()) / 1e6, float(spectrum["freq"].max()) / 1e6)


def _despread_panel(ax, spectrum: xr.Dataset, segments: list[str], span_hz: float = 1000.0) -> None:
    f = spectrum["freq_despread"].values
    keep = np.abs(f) <= span_hz
    for seg in segments:
        ax.plot(f[keep], spectrum["despread_db"].sel(segment=seg).values[keep], color=SEGMENT_COLORS.get(seg), lw=0.9,
                label=f"_{seg}")  # named by the spectrum panel's entry of the same colour
    ax.set_xlim(-span_hz, span_hz)
    ax.set_xlabel("frequency offset from the carrier [Hz]")
    ax.set_ylabel("PSD [dB rel. median]")
    ax.set_title(f"PRN {int(spectrum.attrs['despread_prn'])} after code and Doppler wipe-off "
                 f"({float(spectrum.attrs['despread_rate_hz']) / 1e3:g} kHz coherent sums)", fontsize=8)


def _cn0_panel(ax, cn0: xr.Dataset, t_max: float | None = None) -> None:
    t = cn0["time"].values
    keep = t <= t_max if t_max is not None else np.ones_like(t, dtype=bool)
    for k, prn in enumerate(cn0["prn"].values):
        color = PRN_COLORS[k % len(PRN_COLORS)]
        ax.plot(t[keep], cn0["cn0_est"].isel(sv=k).values[keep], color=color, lw=0.9, marker=".", ms=3, label=f"PRN {int(prn)} estimated")
        ax.plot(t[keep], cn0["cn0_true"].isel(sv=k).values[keep], color=color, lw=0.8, ls="--")
    ax.plot([], [], color="k", ls="--", lw=0.8, label="true C/N$_0$ (dashed, each PRN)")
    onset = float(cn0.attrs["jammer_onset_s"])
    if t_max is None or onset <= t_max:
        ax.axvline(onset, color="0.3", lw=0.9, ls=":", label=f"jammer onset ({onset:g} s)")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("C/N$_0$ [dB-Hz]")


def _cn0_note(cn0: xr.Dataset, t_max: float | None = None) -> str:
    est = cn0["cn0_est"].values
    if t_max is not None:
        est = est[:, cn0["time"].values <= t_max]
    missing = int(np.isnan(est).sum())
    gaps = f"; {missing} of {est.size} windows without estimate (2 m2$^2$ < m4)" if missing else ""
    return (f"M2M4 C/N$_0$ over {float(cn0.attrs['window_s']):g}-s windows of {int(cn0.attrs['coherent_ms'])}-ms prompts\n"
            f"(open loop, replica = truth){gaps}")


def _clean_end(cn0: xr.Dataset) -> float:
    """Centre of the last C/N0 window that ends before the onset."""
    return float(cn0.attrs["jammer_onset_s"]) - float(cn0.attrs["window_s"]) / 2


def _cn0_mean(cn0: xr.Dataset, segment: str) -> float:
    t = cn0["time"].values
    onset = float(cn0.attrs["jammer_onset_s"])
    sel = t <= _clean_end(cn0) if segment == "clean" else t - float(cn0.attrs["window_s"]) / 2 >= onset
    return float(np.nanmean(cn0["cn0_est"].values[:, sel]))


def _cn0_verdict(cn0: xr.Dataset, segment: str, extra: str = "", extra_ok: bool = True) -> Verdict:
    m = _cn0_mean(cn0, segment)
    ok = abs(m - PAPER_CN0[segment]) <= CN0_TOLERANCE_DB[segment] and extra_ok
    return Verdict("reproduced" if ok else "differs",
                   f"{segment} C/N0 estimated {m:.1f} dB-Hz (M2M4, mean over {cn0.sizes['sv']} SVs) vs paper ~{PAPER_CN0[segment]:g} dB-Hz"
                   f"{extra}; the dataset is built at the paper's value")


def verdict_fig05(spectrum, cn0):
    """Reproduced when the mean M2M4 estimate over the clean windows is within 1 dB of the paper's 46 dB-Hz."""
    return _cn0_verdict(cn0, "clean")


@figure("zhao_fig05", "fig05_clean_spectrum_cn0", paper=PAPER, section=SEC_DATA,
        inputs=lambda c: {"spectrum": paths.ZHAO_SPECTRUM, "cn0": paths.ZHAO_CN0},
        number="Fig. 5", claim="The clean signal shows a sinc-shaped peak at the carrier after despreading and a C/N0 of about 46 dB-Hz",
        tables=(), verdict=verdict_fig05)
def zhao_fig05(spectrum, cn0):
    fig, (ax1, ax3, ax2) = new_figure(3, 1, figsize=(6.8, 8.6))
    _spectrum_panel(ax1, spectrum, ["clean"])
    ax1.set_title(f"IQ spectrum, {float(spectrum.attrs['sample_rate_hz']) / 1e6:g} MS/s complex baseband (the signal is below the noise)", fontsize=8)
    _despread_panel(ax3, spectrum, ["clean"])
    clean_end = _clean_end(cn0)
    _cn0_panel(ax2, cn0, t_max=clean_end)
    ax2.set_title(_cn0_note(cn0, clean_end), fontsize=8)
    fig.suptitle(f"Fig. 5: clean signal ({SYNTHETIC})\nclean case = the {float(cn0.attrs['jammer_onset_s']):g} s before the jammer onset "
                 "(the paper ran a separate clean scenario)", fontsize=9)
    fig.tight_layout()
    figure_legend(fig, *handles_of(ax1, ax3, ax2), ncol=3, fontsize=7.5)
    return fig


def verdict_fig08(spectrum, cn0):
    """Reproduced when the mean M2M4 estimate over the jammed windows is within 2 dB of the paper's 15 dB-Hz and the
    jammer's bandwidth is the paper's 8 MHz."""
    bw = float(spectrum.attrs["jammer_bandwidth_hz"])
    return _cn0_verdict(cn0, "jammed", f"; jammer {bw / 1e6:g} MHz wide (paper {PAPER_JAMMER_BW_HZ / 1e6:g} MHz)",
                        abs(bw - PAPER_JAMMER_BW_HZ) < 1.0)


@figure("zhao_fig08", "fig08_jammed_spectrum_cn0", paper=PAPER, section=SEC_DATA,
        inputs=lambda c: {"spectrum": paths.ZHAO_SPECTRUM, "cn0": paths.ZHAO_CN0},
        number="Fig. 8", claim="An 8 MHz noise jammer from 120 s buries the GPS signal and drops the C/N0 to about 15 dB-Hz",
        tables=(), verdict=verdict_fig08)
def zhao_fig08(spectrum, cn0):
    fig, (ax1, ax3, ax2) = new_figure(3, 1, figsize=(6.8, 8.6))
    _spectrum_panel(ax1, spectrum, ["clean", "jammed"])
    _despread_panel(ax3, spectrum, ["clean", "jammed"])
    bw = float(spectrum.attrs["jammer_bandwidth_hz"]) / 1e6
    ax1.set_title(f"IQ spectrum: {bw:g} MHz noise jammer, J/S = {float(spectrum.attrs['jammer_js_db']):.1f} dB per satellite", fontsize=8)
    _cn0_panel(ax2, cn0)
    ax2.set_title(_cn0_note(cn0) + f"; jammed truth {float(cn0.attrs['cn0_jammed_dbhz']):.1f} dB-Hz", fontsize=8)
    fig.suptitle(f"Fig. 8: jammed signal ({SYNTHETIC})", fontsize=9)
    fig.tight_layout()
    figure_legend(fig, *handles_of(ax1, ax3, ax2), ncol=3, fontsize=7.5)
    return fig


#: the paper's satellites (Sec. IV)
PAPER_PRNS = (1, 11, 28, 30)


def verdict_skyplot(dataset):
    """No paper figure (the paper lists the satellites only).  The line gives the scenario's PRNs beside the
    paper's, the elevation range and the GDOP range."""
    prns = tuple(int(p) for p in dataset["prn"].values)
    el = dataset["elevation"].values
    same = "as in the paper" if sorted(prns) == sorted(PAPER_PRNS) else f"paper: PRN {', '.join(map(str, PAPER_PRNS))}"
    return Verdict("no paper figure", f"PRN {', '.join(map(str, prns))} ({same}); elevations {np.min(el):.0f}-{np.max(el):.0f} deg, "
                                      f"GDOP {float(dataset['gdop'].min()):.1f}-{float(dataset['gdop'].max()):.1f}")


@figure("zhao_skyplot", "skyplot", paper=PAPER, section=SEC_DATA, inputs=lambda c: {"dataset": paths.gps_dataset_path(c)},
        number=None, claim="No paper figure: the paper's static receiver near Chicago sees PRN 1, 11, 28 and 30 for 4 minutes",
        tables=(), verdict=verdict_skyplot)
def zhao_skyplot(dataset):
    """Each satellite's track over the scenario (dot: start), labelled with its PRN and starting elevation."""
    with_polar = {"subplot_kw": {"projection": "polar"}}
    fig, ax = new_figure(1, 1, figsize=(5.4, 5.8), **with_polar)
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    for k, prn in enumerate(dataset["prn"].values):
        color = PRN_COLORS[k % len(PRN_COLORS)]
        az = np.radians(dataset["azimuth"].isel(sv=k).values)
        el = dataset["elevation"].isel(sv=k).values
        ax.plot(az, 90.0 - el, color=color, lw=2)
        ax.plot(az[0], 90.0 - el[0], "o", color=color, ms=4)
        ax.annotate(f"PRN {int(prn)}\n{el[0]:.0f}°", (az[-1], 90.0 - el[-1]), xytext=(6, 0), textcoords="offset points", fontsize=8, color=color)
    ax.set_rlim(0, 90)
    ax.set_yticks([0, 30, 60, 80])
    ax.set_yticklabels(["90°", "60°", "30°", "10°"], fontsize=7.5)
    ax.set_xticks(np.radians([0, 90, 180, 270]))
    ax.set_xticklabels(["N", "E", "S", "W"])
    a = dataset.attrs
    ax.set_title(
        f"Sky plot, {a['window_start_utc']} UTC + {float(a['duration_s']):g} s (dot: start; label: elevation at start)\n"
        f"receiver {float(a['receiver_lat_deg']):.5f}°, {float(a['receiver_lon_deg']):.5f}°; "
        f"GDOP {float(dataset['gdop'].min()):.1f}-{float(dataset['gdop'].max()):.1f}, "
        f"PDOP {float(dataset['pdop'].min()):.1f}-{float(dataset['pdop'].max()):.1f}\n({SYNTHETIC}, real ephemerides {a['ephemerides']})",
        fontsize=8,
    )
    fig.tight_layout()
    return fig


# LNAV fields drawn on the frame plot: (subframe, name, first bit, length); 1-based subframe bits.
_COMMON = [("TLM preamble", 1, 8), ("HOW TOW", 31, 17), ("subframe ID", 50, 3)]
_MARKS = {
    1: [("WN", 61, 10), ("IODC", 83, 2), ("T_GD", 197, 8), ("IODC", 211, 8), ("t_oc", 219, 16), ("a_f2, a_f1", 241, 24), ("a_f0", 271, 22)],
    2: [("IODE", 61, 8), ("M0", 107, 8), ("M0", 121, 24), ("e", 167, 8), ("e", 181, 24), ("sqrtA", 227, 8), ("sqrtA", 241, 24), ("t_oe", 271, 16)],
    3: [("Omega0", 77, 8), ("Omega0", 91, 24), ("i0", 137, 8), ("i0", 151, 24), ("omega", 197, 8), ("omega", 211, 24), ("IODE", 271, 8), ("IDOT", 279, 14)],
    4: [("data ID, SV ID (page)", 61, 8)],
    5: [("data ID, SV ID (page)", 61, 8)],
}
#: grey levels of the bit cells: (bit 1, bit 0) of data bits and of parity bits D25-D30
BIT_SHADES = {"data": (0.0, 1.0), "parity": (0.35, 0.78)}


def field_styles(names: list[str]) -> dict[str, tuple]:
    """One (colour, line style) per field name, none repeated: the ten tab10 colours solid, then dashed."""
    import matplotlib

    tab10 = [matplotlib.colormaps["tab10"](i) for i in range(10)]
    styles = [(c, "-") for c in tab10] + [(c, "--") for c in tab10] + [(c, ":") for c in tab10]
    if len(names) > len(styles):
        raise ValueError(f"{len(names)} LNAV fields but only {len(styles)} distinct styles")
    return {name: styles[i] for i, name in enumerate(names)}


def verdict_lnav(dataset):
    """No paper figure (the frame documents the message the MM filter's bit priors come from).  The line gives the
    frame's PRN, start time, data set and the share of its bits that are parity."""
    prn = int(dataset["prn"].values[0])
    starts, ids = dataset["subframe_start"].values, dataset["subframe_id"].values
    first = int(np.flatnonzero((starts >= 0.0) & (ids == 1))[0])
    iode = int(dataset["iode"].isel(sv=0, subframe=first + 1).values)
    return Verdict("no paper figure", f"LNAV frame of PRN {prn} from t = {starts[first]:g} s, data set IODE {iode}; "
                                      f"{100 * 6 / 30:.0f}% of its 1500 bits are parity")


@figure("zhao_lnav", "lnav_frame", paper=PAPER, section=SEC_DATA, inputs=lambda c: {"dataset": paths.gps_dataset_path(c)},
        number=None, claim="No paper figure: one frame of the LNAV message whose bits the MM filter predicts",
        tables=(), verdict=verdict_lnav)
def zhao_lnav(dataset):
    """The first complete frame at/after the scenario start of the first satellite, bit by bit.

    Data bits are black (1) / white (0); the parity bits D25-D30 of each word are drawn in two greys (dark = 1,
    light = 0), so the parity columns read as bits too.  Each field has its own colour and line style (tab10
    colours solid, then dashed): no two fields share a style."""
    import matplotlib.patches as mpatches

    sv = 0
    prn = int(dataset["prn"].values[sv])
    starts = dataset["subframe_start"].values
    ids = dataset["subframe_id"].values
    first = int(np.flatnonzero((starts >= 0.0) & (ids == 1))[0])
    bits = dataset["nav_bits"].isel(sv=sv).values
    bit_t = dataset["nav_bit_time"].values
    b0 = int(np.argmin(np.abs(bit_t - starts[first])))
    frame = bits[b0 : b0 + 1500].reshape(5, 300).astype(float)
    parity = (np.arange(300) % 30) >= 24
    shade = np.where(frame > 0.5, BIT_SHADES["data"][0], BIT_SHADES["data"][1])
    shade[:, parity] = np.where(frame[:, parity] > 0.5, BIT_SHADES["parity"][0], BIT_SHADES["parity"][1])
    fig, ax = new_figure(1, 1, figsize=(10.0, 5.2))
    ax.imshow(np.repeat(shade[:, :, None], 3, axis=2), aspect="auto", interpolation="nearest", extent=(0.5, 300.5, 5.5, 0.5))
    ax.grid(False)
    names = list(dict.fromkeys(name for row in range(1, 6) for name, _b, _n in _COMMON + _MARKS[row]))
    styles = field_styles(names)
    for row in range(1, 6):
        for name, b, n in _COMMON + _MARKS[row]:
            c, ls = styles[name]
            ax.add_patch(mpatches.Rectangle((b - 0.5, row - 0.42), n, 0.84, fill=False, ec=c, ls=ls, lw=1.5))
    field_handles = [mpatches.Patch(fill=False, ec=styles[n][0], ls=styles[n][1], lw=1.5, label=n) for n in names]
    bit_handles = [mpatches.Patch(facecolor=str(v), edgecolor="0.5", label=lab) for v, lab in (
        (BIT_SHADES["data"][0], "data bit 1"), (BIT_SHADES["data"][1], "data bit 0"),
        (BIT_SHADES["parity"][0], "parity bit 1 (D25-D30 of each word)"), (BIT_SHADES["parity"][1], "parity bit 0"))]
    handles = bit_handles + field_handles
    kind = str(dataset["dataset_kind"].isel(sv=sv, subframe=first).values)
    iode = int(dataset["iode"].isel(sv=sv, subframe=first + 1).values)
    page = int(dataset["page"].isel(subframe=first + 3).values)
    ax.set_yticks(range(1, 6))
    ax.set_yticklabels([f"SF{k}" for k in range(1, 6)])
    ax.set_xticks([1, 31, 61, 91, 121, 151, 181, 211, 241, 271, 300])
    ax.set_xlabel("bit in subframe (word boundaries every 30 bits; bits as transmitted)")
    ax.set_title(
        f"LNAV frame of PRN {prn} starting at t = {starts[first]:g} s (SF4/5 page {page}; data set IODE {iode}, {kind})\n"
        f"boxes: the fields of each subframe ({SYNTHETIC})",
        fontsize=9,
    )
    fig.tight_layout()
    figure_legend(fig, handles, [h.get_label() for h in handles], ncol=5, fontsize=7.5)
    return fig
