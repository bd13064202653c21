"""Figures of Zhao, Khanafseh & Pervan (MM Kalman filter through wideband jamming): the dataset's figures.

The paper's Fig. 5 (clean signal) and Fig. 8 (jammed signal) show the
spectrum of the recorded IQ and the C/N0 over the run; here both come from
our SKYDEL-like dataset: the Welch spectrum of the IQ recording's clean and
jammed segments (``results/zhao_jamming/iq_spectrum.nc``) and the C/N0
estimated from correlator outputs by the M2M4 estimator beside the truth
(``results/zhao_jamming/cn0_estimates.nc``).  A sky plot of the scenario's
satellites and a plot of one LNAV frame with its fields marked document
the dataset itself.  Every title says the data are synthetic.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ...pipeline import paths
from ..registry import figure
from .common import new_figure

if TYPE_CHECKING:
    import xarray as xr

PAPER = "zhao_jamming"
SEC_DATA = "Zhao et al.: jammed SKYDEL-like dataset"
SYNTHETIC = "synthetic SKYDEL-like data"


def _spectrum_panel(ax, spectrum: xr.Dataset, segments: list[str]) -> None:
    styles = {"clean": {"color": "tab:blue", "lw": 0.8}, "jammed": {"color": "tab:red", "lw": 0.8}}
    for seg in segments:
        s = spectrum.sel(segment=seg)
        ax.plot(s["freq"].values / 1e6, s["psd_db"].values, label=f"{seg} (t = {float(s['start_s']):g} s)", **styles.get(seg, {}))
    ax.set_xlabel("frequency offset from L1 [MHz]")
    ax.set_ylabel("PSD [dB/Hz, rel. full scale]")
    ax.set_xlim(float(spectrum["freq"].min()) / 1e6, float(spectrum["freq"].max()) / 1e6)
    ax.legend(loc="lower center")


def _despread_panel(ax, spectrum: xr.Dataset, segments: list[str], span_hz: float = 1000.0) -> None:
    styles = {"clean": {"color": "tab:blue", "lw": 0.8}, "jammed": {"color": "tab:red", "lw": 0.8}}
    f = spectrum["freq_despread"].values
    keep = np.abs(f) <= span_hz
    for seg in segments:
        ax.plot(f[keep], spectrum["despread_db"].sel(segment=seg).values[keep], label=seg, **styles.get(seg, {}))
    ax.set_xlim(-span_hz, span_hz)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("PSD [dB rel. median]")
    ax.set_title(f"PRN {int(spectrum.attrs['despread_prn'])} after code and Doppler wipe-off "
                 f"({float(spectrum.attrs['despread_rate_hz']) / 1e3:g} kHz coherent sums)", fontsize=8)
    ax.legend(loc="upper right")


def _cn0_panel(ax, cn0: xr.Dataset, t_max: float | None = None) -> None:
    t = cn0["time"].values
    keep = t <= t_max if t_max is not None else np.ones_like(t, dtype=bool)
    for k, prn in enumerate(cn0["prn"].values):
        color = f"C{k}"
        ax.plot(t[keep], cn0["cn0_est"].isel(sv=k).values[keep], color=color, lw=0.9, label=f"PRN {int(prn)} estimated")
        ax.plot(t[keep], cn0["cn0_true"].isel(sv=k).values[keep], color=color, lw=0.8, ls="--")
    ax.plot([], [], color="k", ls="--", lw=0.8, label="truth")
    onset = float(cn0.attrs["jammer_onset_s"])
    if t_max is None or onset <= t_max:
        ax.axvline(onset, color="0.4", lw=0.8, ls=":")
        ax.annotate("jammer on", (onset, ax.get_ylim()[1]), xytext=(3, -12), textcoords="offset points", fontsize=8)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("C/N$_0$ [dB-Hz]")
    ax.legend(ncol=2, fontsize=7)


def _cn0_note(cn0: xr.Dataset, t_max: float | None = None) -> str:
    est = cn0["cn0_est"].values
    if t_max is not None:
        est = est[:, cn0["time"].values <= t_max]
    missing = int(np.isnan(est).sum())
    gaps = f"\n{missing} of {est.size} windows without estimate (moments give 2 m2$^2$ < m4)" if missing else ""
    return (f"M2M4 over {float(cn0.attrs['window_s']):g} s of {int(cn0.attrs['coherent_ms'])}-ms prompts "
            f"(open loop, replica = truth), dashed: truth{gaps}")


@figure("zhao_fig05", "fig05_clean_spectrum_cn0", paper=PAPER, section=SEC_DATA,
        inputs=lambda c: {"spectrum": paths.ZHAO_SPECTRUM, "cn0": paths.ZHAO_CN0})
def zhao_fig05(spectrum, cn0):
    fig, (ax1, ax3, ax2) = new_figure(3, 1, figsize=(6.4, 8.4))
    _spectrum_panel(ax1, spectrum, ["clean"])
    ax1.set_title(f"IQ spectrum, {float(spectrum.attrs['sample_rate_hz']) / 1e6:g} MS/s complex baseband")
    _despread_panel(ax3, spectrum, ["clean"])
    clean_end = float(cn0.attrs["jammer_onset_s"]) - float(cn0.attrs["window_s"]) / 2  # windows that end before the onset
    _cn0_panel(ax2, cn0, t_max=clean_end)
    ax2.set_title(_cn0_note(cn0, clean_end), fontsize=7.5)
    fig.suptitle(f"Fig. 5: clean signal ({SYNTHETIC})")
    fig.tight_layout()
    return fig


@figure("zhao_fig08", "fig08_jammed_spectrum_cn0", paper=PAPER, section=SEC_DATA,
        inputs=lambda c: {"spectrum": paths.ZHAO_SPECTRUM, "cn0": paths.ZHAO_CN0})
def zhao_fig08(spectrum, cn0):
    fig, (ax1, ax3, ax2) = new_figure(3, 1, figsize=(6.4, 8.4))
    _spectrum_panel(ax1, spectrum, ["clean", "jammed"])
    _despread_panel(ax3, spectrum, ["clean", "jammed"])
    bw = float(spectrum.attrs["jammer_bandwidth_hz"]) / 1e6
    ax1.set_title(f"IQ spectrum: {bw:g} MHz noise jammer, J/S = {float(spectrum.attrs['jammer_js_db']):.1f} dB per satellite")
    _cn0_panel(ax2, cn0)
    ax2.set_title(_cn0_note(cn0) + f"; jammed truth {float(cn0.attrs['cn0_jammed_dbhz']):.1f} dB-Hz", fontsize=7.5)
    fig.suptitle(f"Fig. 8: jammed signal ({SYNTHETIC})")
    fig.tight_layout()
    return fig


@figure("zhao_skyplot", "skyplot", paper=PAPER, section=SEC_DATA, inputs=lambda c: {"dataset": paths.gps_dataset_path(c)})
def zhao_skyplot(dataset):
    with_polar = {"subplot_kw": {"projection": "polar"}}
    fig, ax = new_figure(1, 1, figsize=(5.4, 5.6), **with_polar)
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    for k, prn in enumerate(dataset["prn"].values):
        az = np.radians(dataset["azimuth"].isel(sv=k).values)
        el = dataset["elevation"].isel(sv=k).values
        ax.plot(az, 90.0 - el, color=f"C{k}", lw=2)
        ax.plot(az[0], 90.0 - el[0], "o", color=f"C{k}", ms=4)
        ax.annotate(f"PRN {int(prn)}\n{el[0]:.0f}°", (az[-1], 90.0 - el[-1]), xytext=(6, 0), textcoords="offset points", fontsize=8, color=f"C{k}")
    ax.set_rlim(0, 90)
    ax.set_yticks([0, 30, 60, 80])
    ax.set_yticklabels(["90°", "60°", "30°", "10°"])
    a = dataset.attrs
    ax.set_title(
        f"Sky plot, {a['window_start_utc']} UTC + {float(a['duration_s']):g} s\n"
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


@figure("zhao_lnav", "lnav_frame", paper=PAPER, section=SEC_DATA, inputs=lambda c: {"dataset": paths.gps_dataset_path(c)})
def zhao_lnav(dataset):
    """The first complete frame at/after the scenario start of the first satellite, bit by bit."""
    import matplotlib
    import matplotlib.patches as mpatches

    sv = 0
    prn = int(dataset["prn"].values[sv])
    starts = dataset["subframe_start"].values
    ids = dataset["subframe_id"].values
    first = int(np.flatnonzero((starts >= 0.0) & (ids == 1))[0])
    bits = dataset["nav_bits"].isel(sv=sv).values
    bit_t = dataset["nav_bit_time"].values
    b0 = int(np.argmin(np.abs(bit_t - starts[first])))
    frame = bits[b0 : b0 + 1500].reshape(5, 300)
    fig, ax = new_figure(1, 1, figsize=(11.0, 4.4))
    ax.imshow(frame, aspect="auto", cmap="Greys", interpolation="nearest", extent=(0.5, 300.5, 5.5, 0.5))
    for w in range(10):
        ax.axvspan(30 * w + 24.5, 30 * w + 30.5, color="tab:gray", alpha=0.35, lw=0)
    palette = [matplotlib.colormaps["tab10"](i) for i in range(10)] + [matplotlib.colormaps["Dark2"](i) for i in range(8)]
    colors = {}
    for row in range(1, 6):
        marks = _COMMON + _MARKS[row]
        for name, b, n in marks:
            c = colors.setdefault(name, palette[len(colors) % len(palette)])
            ax.add_patch(mpatches.Rectangle((b - 0.5, row - 0.42), n, 0.84, fill=False, ec=c, lw=1.4))
    parity = mpatches.Patch(color="tab:gray", alpha=0.35, label="parity D25-D30 (last 6 bits of each word)")
    handles = [mpatches.Patch(fill=False, ec=c, lw=1.4, label=n) for n, c in colors.items()] + [parity]
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=6, fontsize=7, frameon=False)
    kind = str(dataset["dataset_kind"].isel(sv=sv, subframe=first).values)
    iode = int(dataset["iode"].isel(sv=sv, subframe=first + 1).values)
    page = int(dataset["page"].isel(subframe=first + 3).values)
    ax.set_yticks(range(1, 6))
    ax.set_yticklabels([f"SF{k}" for k in range(1, 6)])
    ax.set_xlabel("bit in subframe (black = 1, as transmitted)")
    ax.set_title(
        f"LNAV frame of PRN {prn} starting at t = {starts[first]:g} s (SF4/5 page {page}; data set IODE {iode}, {kind}) ({SYNTHETIC})",
        fontsize=9,
    )
    fig.tight_layout()
    return fig
