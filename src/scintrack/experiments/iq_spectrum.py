"""Spectra of the IQ recordings (Zhao et al., Figs. 5 and 8: clean and jammed signal).

Two views of each segment:

* the raw complex baseband (``scipy.signal.welch``, Hann window, 50 %
  overlap, two-sided, frequencies ascending), in dB relative to the
  recording's full scale per Hz: at 46 dB-Hz the C/A signals lie 25 dB under
  the thermal noise of a 12.5-MHz band, so the clean spectrum is the noise
  floor and the jammed one shows the 8-MHz jammer;
* the *despread* signal of one satellite: the samples multiplied by its C/A
  replica and carrier at the truth's code phase and Doppler, summed to
  ``DESPREAD_RATE_HZ`` (coherent averaging over 10 us) and Welch-averaged,
  in dB relative to the median level: the carrier (with its 50-bit/s data
  modulation) stands out of the noise at 46 dB-Hz by C/(N0 RBW) and sinks
  below it at the jammed C/N0.  This is our reading of the paper's "clear
  peak at the center frequency with a sinc function shape due to the
  coherent averaging"; the paper does not say how its spectrum was computed.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import xarray as xr
from scipy import signal

from ..signals.gps.acquisition import local_code

DESPREAD_RATE_HZ = 100_000.0


def welch_db(samples: np.ndarray, fs: float, nperseg: int) -> tuple[np.ndarray, np.ndarray]:
    """(frequency Hz ascending, PSD dB/Hz) of complex ``samples``."""
    f, pxx = signal.welch(samples, fs=fs, window="hann", nperseg=min(nperseg, len(samples)), return_onesided=False, detrend=False, scaling="density")
    order = np.argsort(f)
    return f[order], 10.0 * np.log10(np.maximum(pxx[order], 1e-300))


def despread(samples: np.ndarray, fs: float, prn: int, code_phase_chips: float, doppler_hz: float, rate_hz: float = DESPREAD_RATE_HZ) -> np.ndarray:
    """Code and Doppler wiped off, then summed over blocks of ``fs / rate_hz`` samples (must divide)."""
    block = int(round(fs / rate_hz))
    if abs(block * rate_hz - fs) > 1e-6 * fs:
        raise ValueError(f"despread rate {rate_hz} Hz must divide the sample rate {fs} Hz")
    n = (len(samples) // block) * block
    t = np.arange(n) / fs
    wiped = samples[:n] * local_code(prn, fs, n, code_phase_chips, doppler_hz) * np.exp(-2j * np.pi * doppler_hz * t)
    return wiped.reshape(-1, block).sum(axis=1)


def spectra(segments: Mapping[str, tuple[np.ndarray, dict]], truth: Mapping[str, tuple[float, float]], prn: int,
            nperseg: int, order: Sequence[str]) -> xr.Dataset:
    """Spectra of named segments ``{name: (samples in full-scale units, sidecar)}``; ``truth[name]`` = (code phase, Doppler) of ``prn`` at sample 0."""
    psd, dpsd, starts = [], [], []
    freq = dfreq = None
    fs = None
    for name in order:
        samples, sidecar = segments[name]
        fs = float(sidecar["sample_rate_hz"])
        freq, p = welch_db(samples, fs, nperseg)
        psd.append(p)
        d = despread(samples, fs, prn, *truth[name])
        dfreq, dp = welch_db(d, DESPREAD_RATE_HZ, nperseg)
        dpsd.append(dp - np.median(dp))
        starts.append(float(sidecar["segment_start_s"]))
    ds = xr.Dataset(
        {
            "psd_db": (("segment", "freq"), np.array(psd), {"long_name": "power spectral density", "units": "dB (full scale^2/Hz)"}),
            "despread_db": (("segment", "freq_despread"), np.array(dpsd), {"long_name": f"PSD of PRN {prn} after code and Doppler wipe-off", "units": "dB rel. median"}),
        },
        coords={
            "segment": ("segment", list(order)),
            "freq": ("freq", freq, {"units": "Hz"}),
            "freq_despread": ("freq_despread", dfreq, {"units": "Hz"}),
            "start_s": ("segment", np.array(starts), {"units": "s"}),
        },
    )
    jam = segments[order[-1]][1].get("jammer") or {}
    ds.attrs.update(sample_rate_hz=fs, nperseg=int(nperseg), despread_prn=int(prn), despread_rate_hz=DESPREAD_RATE_HZ,
                    jammer_js_db=float(jam.get("js_db", np.nan)), jammer_bandwidth_hz=float(jam.get("bandwidth_hz", np.nan)), source="synthetic")
    return ds
