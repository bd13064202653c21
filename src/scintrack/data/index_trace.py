"""A scintillation trace driven by real per-minute indices: phase with the measured ``T f^-p`` spectrum.

Septentrio receivers report, per satellite and minute, the phase spectrum's
strength ``T`` (the one-sided PSD at 1 Hz, rad^2/Hz) and slope ``p``
(fitted over 0.1-25 Hz), Phi60 and S4 (:mod:`scintrack.data.biscef`).  The
Susi study's event scenario needs a 1-ms phase whose in-band content
(2-20 Hz, where the loops differ) is the real one, which Phi60 alone does
not fix.  This module makes it:

* **phase**: one white Gaussian realisation ``w`` is shaped by each minute's
  spectrum, ``x_k = irfft(rfft(w) sqrt(S_k / (2 ts)))`` with
  ``S_k(f) = T_k max(f, f_floor)^-p_k`` (one-sided, so that Welch's
  one-sided density of ``x_k`` is ``S_k``; white noise of unit variance has
  the one-sided density ``2 ts``).  The trace is the linear crossfade of the
  ``x_k`` between minute centres (constant before the first centre and after
  the last), i.e. one filter whose spectrum moves with the minutes; then it is
  high-passed at ``detrend_hz`` by the ISM receivers' zero-phase 6th-order
  Butterworth (:func:`scintrack.estimators.sigma_phi.detrend_phase`), so its
  60-s sigma_phi is comparable with the real Phi60.  Below ``f_floor`` the
  spectrum is held flat (the high-pass removes that band anyway); above
  25 Hz the fitted power law is extrapolated to Nyquist (it adds little:
  ``p`` > 2 puts the variance at the low end).
* **strength** (``strength``): the minutes' ``Ts1`` are not the strength of
  a one-sided rad^2/Hz spectrum that integrates to their Phi60: over the
  11 196 GPS minutes at >= 35 dB-Hz of both stations, Phi60^2 is a median
  3 % (5-95 %: 0.35-67 %) of ``int T f^-p |H|^2`` over 0.1-25 Hz.  So
  ``phi60`` (the default) keeps the real slope ``p`` and sets ``T`` so that
  the expected square of the trace's 60-s sigma_phi is the real Phi60^2
  (:func:`detrended_variance`; Phi60 is the receiver's direct measurement
  of the phase variance); ``T`` uses the real ``Ts1`` as given.  The
  high-pass is the package's zero-phase form (``|H|^4``,
  :func:`~scintrack.estimators.sigma_phi.detrend_phase`), as every sigma_phi
  of the package; the receivers filter causally (``|H|^2``), which leaves a
  little more power just above 0.1 Hz in their Phi60.
* **amplitude**: intensity ``exp(sigma g - sigma^2 / 2)`` with ``g`` an
  independent unit-variance Gaussian of the same shaping (normalised) and
  ``sigma^2 = ln(1 + S4^2)``, the log-normal intensity whose S4 is the
  minute's; amplitude 1 where S4 is 0 (high-latitude minutes mostly are).

The result is synthetic (a surrogate of the real event): its ``source``
attribute is ``surrogate`` and its title says "SURROGATE driven by REAL
indices", so every product made from it is labelled so.  It stores the real
per-minute indices beside the trace's own 60-s S4 and sigma_phi.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from ..estimators.s4 import window_s4
from ..estimators.sigma_phi import detrend_phase
from ..seeding import rng_for

GENERATOR = "scintrack.data.index_trace"
MINUTE_S = 60.0


def power_law_filter(n: int, ts: float, T: float, p: float, f_floor_hz: float) -> np.ndarray:
    """Amplitude response on ``rfftfreq(n, ts)`` turning unit white noise into one-sided PSD ``T max(f, f_floor)^-p``."""
    f = np.fft.rfftfreq(n, ts)
    psd = T * np.maximum(f, f_floor_hz) ** (-p)
    psd[0] = 0.0  # no mean
    return np.sqrt(psd / (2.0 * ts))


def detrended_variance(ts: float, T: float, p: float, f_floor_hz: float, detrend_hz: float, window_s: float = MINUTE_S,
                       n: int = 2**20) -> float:
    """Expected variance about its own mean, over one ``window_s`` window, of the ``T f^-p`` process after the zero-phase
    high-pass ``H``: ``int_0^{1/(2 ts)} S(f) |H(f)|^4 (1 - sinc^2(f window_s)) df`` (``|H|^4``: the filter runs forward and
    backward; the sinc term is the power the window's mean removes), i.e. the expected square of a Phi60-like index."""
    from scipy import signal

    from ..estimators.sigma_phi import detrend_sos

    f = np.fft.rfftfreq(n, ts)[1:]
    _, h = signal.sosfreqz(detrend_sos(ts, detrend_hz), worN=f, fs=1.0 / ts)
    psd = T * np.maximum(f, f_floor_hz) ** (-p)
    return float(np.sum(psd * np.abs(h) ** 4 * (1.0 - np.sinc(f * window_s) ** 2)) * (f[1] - f[0]))


def strengths(run: Mapping[str, Any], ts: float, f_floor_hz: float, detrend_hz: float, strength: str,
              window_s: float = MINUTE_S) -> np.ndarray:
    """Per-minute ``T`` of the trace: the real ``T`` (``strength: T``), or the ``T`` whose expected squared window
    sigma_phi (:func:`detrended_variance`) is the minute's real Phi60 squared at the minute's real slope (``strength: phi60``)."""
    T, p = np.asarray(run["T"], dtype=float), np.asarray(run["p"], dtype=float)
    if strength == "T":
        return T
    if strength != "phi60":
        raise ValueError(f"strength must be 'phi60' or 'T', not {strength!r}")
    phi = np.asarray(run["phi60"], dtype=float)
    return np.array([ph**2 / detrended_variance(ts, 1.0, pk, f_floor_hz, detrend_hz, window_s) for ph, pk in zip(phi, p)])


def crossfade_weight(n: int, ts: float, n_minutes: int, k: int, minute_s: float = MINUTE_S) -> np.ndarray:
    """Weight of minute ``k`` at each sample: linear between minute centres, 1 at its centre; the weights of all minutes sum to 1."""
    centres = (np.arange(n_minutes) + 0.5) * minute_s
    return np.interp(np.arange(n) * ts, centres, np.eye(n_minutes)[k])


def shaped(white: np.ndarray, ts: float, T: Sequence[float], p: Sequence[float], f_floor_hz: float, minute_s: float = MINUTE_S) -> np.ndarray:
    """``white`` shaped by each minute's ``T f^-p`` and crossfaded between minute centres."""
    n = white.size
    spec = np.fft.rfft(white)
    out = np.zeros(n)
    for k, (tk, pk) in enumerate(zip(T, p)):
        out += crossfade_weight(n, ts, len(T), k, minute_s) * np.fft.irfft(spec * power_law_filter(n, ts, float(tk), float(pk), f_floor_hz), n=n)
    return out


def index_trace(params: Mapping[str, Any], run: Mapping[str, Any]) -> xr.Dataset:
    """The canonical L1 trace (amplitude, phase on ``time``) of one real-index run (:func:`.biscef.strongest_run`).

    ``params``: ``seed``, ``name``, ``ts``, ``duration_s``, ``f_floor_hz``,
    ``detrend_hz``, ``strength`` (:func:`strengths`) and ``window_s``, the
    trace's length per real minute (60 s; a shorter one compresses the event
    in time, which only the smoke build does); the run's minutes must cover
    ``duration_s``.
    """
    ts = float(params["ts"])
    n = int(round(float(params["duration_s"]) / ts))
    minute_s = float(params.get("window_s", MINUTE_S))
    per = int(round(minute_s / ts))
    minutes = int(run["minutes"])
    if minutes * per < n:
        raise ValueError(f"the run holds {minutes} minutes of {minute_s:g} s, shorter than the trace's {float(params['duration_s']):g} s")
    p, s4 = (np.asarray(run[k], dtype=float) for k in ("p", "s4"))
    T = strengths(run, ts, float(params["f_floor_hz"]), float(params["detrend_hz"]), str(params["strength"]), minute_s)
    rng = rng_for(int(params["seed"]), f"index_trace/{params['name']}", 0)
    white_phase, white_amp = rng.standard_normal(n), rng.standard_normal(n)
    theta = detrend_phase(shaped(white_phase, ts, T, p, float(params["f_floor_hz"]), minute_s), ts, float(params["detrend_hz"]))
    if np.any(s4 > 0):
        g = shaped(white_amp, ts, np.ones_like(p), p, float(params["f_floor_hz"]), minute_s)
        g /= g.std()
        sigma2 = np.log1p(sum(crossfade_weight(n, ts, minutes, k, minute_s) * s4[k] ** 2 for k in range(minutes)))
        rho = np.sqrt(np.exp(np.sqrt(sigma2) * g - sigma2 / 2.0))
    else:
        rho = np.ones(n)
    m = n // per
    trace_phi60 = np.full(minutes, np.nan)
    trace_s4 = np.full(minutes, np.nan)
    trace_phi60[:m] = theta[: m * per].reshape(m, per).std(axis=1)  # theta is high-passed already (sigma_phi's detrending)
    trace_s4[:m] = window_s4(rho**2, per)
    where = f"{run['station_name']} PRN {int(run['prn'])} from {run['start_utc']} UTC"
    minute = ("minute",)
    ds = xr.Dataset(
        {
            "amplitude": (("band", "time"), rho[None, :].astype(np.float32), {"units": "1", "long_name": "SURROGATE scintillation amplitude rho_s from the real S4"}),
            "phase": (("band", "time"), theta[None, :].astype(np.float32), {"units": "rad", "long_name": "SURROGATE scintillation phase theta_s with the real T f^-p (detrended)"}),
            "real_phi60": (minute, np.asarray(run["phi60"], dtype=float), {"units": "rad", "long_name": "REAL Phi60 of the minute (Phi60s1)"}),
            "real_s4": (minute, s4, {"units": "1", "long_name": "REAL S4 of the minute (S4s1)"}),
            "real_T": (minute, np.asarray(run["T"], dtype=float), {"units": "rad2/Hz", "long_name": "REAL phase PSD at 1 Hz (Ts1)"}),
            "trace_T": (minute, T, {"units": "rad2/Hz", "long_name": "T of the trace's spectrum T f^-p"}),
            "real_p": (minute, p, {"units": "1", "long_name": "REAL phase PSD slope (-ps1)"}),
            "real_cn0": (minute, np.asarray(run["cn0"], dtype=float), {"units": "dB-Hz", "long_name": "REAL C/N0 of the minute"}),
            "trace_phi60": (minute, trace_phi60, {"units": "rad", "long_name": "sigma_phi of the trace over its window of the minute (high-passed)"}),
            "trace_s4": (minute, trace_s4, {"units": "1", "long_name": "S4 of the trace over its window of the minute"}),
            "mean_s4": (("band",), [float(np.nanmean(trace_s4))], {"units": "1", "long_name": "mean of the 60-s S4 of the trace"}),
            "mean_sigma_phi": (("band",), [float(np.nanmean(trace_phi60))], {"units": "rad", "long_name": "mean of the 60-s sigma_phi of the trace"}),
        },
        coords={"band": ["L1"], "time": ("time", np.arange(n) * ts, {"units": "s"}), "minute": np.arange(minutes),
                "minute_utc": (("minute",), list(run["time_utc"]))},
    )
    ds.attrs.update({
        "event": str(params["name"]), "source": "surrogate",
        "title": f"SURROGATE scintillation driven by REAL BiScEF indices ({where}; synthetic phase, not a recording)",
        "generator": GENERATOR, "real_event": where, "real_station": str(run["station"]), "real_prn": int(run["prn"]),
        "real_start_utc": str(run["start_utc"]), "real_median_phi60": float(run["median_phi60"]),
        "phase_detrending": f"zero-phase 6th-order Butterworth high-pass at {float(params['detrend_hz']):g} Hz",
        "strength": str(params["strength"]),
        "spectrum": f"one-sided T f^-p per minute (T: {'the real Ts1' if params['strength'] == 'T' else 'from the real Phi60 at the real p'}), flat below {float(params['f_floor_hz']):g} Hz, crossfaded between minute centres",
    })
    return ds
