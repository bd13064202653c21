"""Closed-loop tracking of a raw-sample recording with the project's own loops: carriers, code and bit edges.

From an acquisition (:func:`scintrack.signals.gps.acquisition.acquire`) of each
satellite, :func:`track_satellite` runs two receiver channels on the samples,
one code period (1 ms) per epoch, each a
:class:`~scintrack.signals.gps.sample_correlator.SampleCorrelator` closed
through a carrier tracker and a carrier-aided DLL:

* **PLL channel**: the Costas PLL of the jamming receiver (config
  ``zhao_pll``: third order, ``Bn`` = 10 Hz, ``atan`` discriminator).  Per
  epoch it is the step of :class:`scintrack.trackers.pll.PLL`:
  :func:`.blocks.atan_discriminator` of the prompt against the NCO phase,
  then :func:`.blocks.pll_step` with :func:`.blocks.pll_constants`.  The
  prompt is handed to it in the loop's own phase frame, ``y = P exp(j psi)``
  with ``psi`` the NCO phase that correlated it, so ``PLL.run`` on the
  recorded ``y`` gives the closed loop's phases and discriminator outputs
  bit for bit (tested).
* **MM channel**: the two-mode multiple-model Kalman filter
  (:class:`scintrack.trackers.mm_kf.MMKF`, Zhao et al.; config ``zhao_mm``'s
  ``zhao_tcxo`` clock) with no bit prediction (``P(d = +1) = 1/2`` every
  epoch), run epoch by epoch by its own compiled loop
  :func:`scintrack.trackers.mm_kf.mm_kf_loop`, resumed at each epoch from the
  previous epoch's posterior (the mechanism of ``MMKF.resume``: a run resumed
  at epoch ``j`` has the bits of one run from epoch 0, so
  :func:`~scintrack.trackers.mm_kf.mm_kf_kernel` on the recorded
  observations gives the closed loop's phases bit for bit, tested).  Its state
  ``[A, phi, f]`` is relative to a reference carrier fixed at the hand-over
  (the PLL channel's phase and frequency there); the NCO of each epoch is the
  predicted state ``F x``.  The channel starts ``pull_in_ms`` after the PLL,
  from the PLL channel's phase, frequency and code NCO (a Kalman-filter
  tracker taking over from the loop that pulled the signal in); its M2M4
  noise prior and initial amplitude come from the PLL channel's prompts of
  the ``m2m4_window`` epochs before.  It runs at 1 ms, not on 20-ms bit
  sums as in the jamming receiver: before bit synchronisation there are no
  bit-synchronous sums, and with both modes open every epoch the filter is
  insensitive to the data.
* **DLL** (both channels): the noncoherent early-minus-late discriminator and
  first-order loop gain of :mod:`scintrack.navigation.dll`
  (:func:`~scintrack.navigation.dll.discriminator`,
  :func:`~scintrack.navigation.dll.loop_gain`), 1-ms integrations (noncoherent,
  so a bit edge between epochs does not matter), ``B_L`` = 2 Hz, code rate
  carrier-aided by the channel's own carrier frequency,
  ``f_code = 1.023e6 (1 + f / f_L1) - K D``.

Pull-in.  An acquisition's Doppler bin is off by up to half the bin spacing
(333 Hz for the 667-Hz bins of 1-ms blocks), beyond what a 10-Hz Costas PLL
can pull in: its discriminator sees a quarter cycle per ms at 250 Hz, and on
the Pocket SDR capture, started at the acquisition's bins (500 Hz apart), it
locks on none of the five strong satellites.  :func:`refine_acquisition`
narrows Doppler and code phase first, open loop, on the first
``fine_search_ms`` of samples (a look-ahead, as the acquisition itself is):

* Doppler: the 1-ms prompts of :func:`~scintrack.signals.gps.acquisition.correlate`
  at the acquisition's code phase and Doppler are squared (which removes the
  data bits) and the peak of their zero-padded spectrum (scipy.fft) is twice
  the residual frequency; the 500-Hz ambiguity of the 1-kHz prompt rate is
  settled by the prompt power at each of the three candidates (residuals up
  to 750 Hz are resolved);
* code phase: the DLL discriminator of the early and late envelopes averaged
  over those prompts, applied ``code_passes`` (3) times (the envelopes'
  noise bias flattens the discriminator's slope at low C/N0, so one pass
  leaves part of a large error; at 38 dB-Hz a 0.3-chip error ends below 0.05).

The PLL then starts at the refined Doppler with the Costas phase of the first
code period's prompt (that period correlated once at phase 0), so it starts
within a fraction of a radian and a hertz and pulls in at its own bandwidth:
on the capture it is in lock from the first epochs.  Neither an FLL nor a
wider pull-in bandwidth is needed: 20 or 30 Hz over the first 100 ms only
made the frequency swing two to four times as far as at 10 Hz.  ``pull_in_ms`` (100 ms) is
the span left out of the statistics and the PLL's lead over the MM channel.

Per-epoch outputs (:func:`track_satellite`: an xarray Dataset over ``epoch``,
one code period each, NaN where a channel has not started or the samples ran
out): E/P/L of the PLL channel, its discriminator output (the Costas phase
error), NCO phase, carrier frequency and rate, replica code phase and rate,
DLL discriminator; the MM channel's prompt, observation, posterior phase,
phase error (the Costas phase of its prompt against its NCO: the same measure
as the PLL's) and frequency; the C/N0 of the PLL prompts by the sliding M2M4
estimator (:class:`scintrack.estimators.cn0.StreamingM2M4`, ``cn0_window_ms``
= 100 ms); the lock state of :func:`scintrack.experiments.lock_detector.lock_state`
on the PLL discriminator output (running mean of ``|e|`` at or below
``lock_threshold_rad`` = 0.5 rad, the receiver's threshold, over
``lock_window_s`` = 50 ms instead of the receiver's 1 s, which is longer
than a 0.5-s capture).

:func:`summary` reduces a tracked recording to one row per satellite, over
the epochs after ``pull_in_ms``: mean C/N0, lock fraction, bit
synchronisation (:mod:`scintrack.signals.gps.bit_sync`) on the PLL prompts
(offset as an epoch index and as the code-epoch time modulo 20 ms from the
first sample, transitions seen, fraction of sign changes on the offset) and
the standard deviations of both channels' phase errors.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np
import xarray as xr
from scipy import fft

from ..estimators.cn0 import StreamingM2M4, cn0_from_powers, to_dbhz
from ..navigation import dll
from ..signals.gps import bit_sync as bitsync
from ..signals.gps.acquisition import Acquisition, correlate
from ..signals.gps.ca_code import CHIPS
from ..signals.gps.iq import MS, code_rate_hz
from ..signals.gps.sample_correlator import PeriodCorrelation, SampleCorrelator
from ..trackers import blocks
from ..trackers.base import TrackInit
from ..trackers.mm_kf import COV_ENTRIES, MMKF, mm_kf_loop
from ..trackers.pll import PLL
from .lock_detector import lock_state

#: the code period (s): the loops' epoch
TS = MS


@dataclass(frozen=True)
class TrackingSettings:
    """Loop parameters of :func:`track_satellite` (module docstring)."""

    pll: PLL = field(default_factory=lambda: PLL(ts=TS, bandwidth_hz=10.0, discriminator="atan"))
    mm: MMKF = field(default_factory=lambda: MMKF(ts=TS, m2m4_window=50))
    pull_in_ms: int = 100
    fine_search_ms: int = 100
    code_passes: int = 3
    dll_bandwidth_hz: float = 2.0
    spacing_chips: float = 1.0
    cn0_window_ms: int = 100
    lock_threshold_rad: float = 0.5
    lock_window_s: float = 0.05

    def __post_init__(self):
        if self.pll.discriminator != "atan":
            raise ValueError("the PLL must use the Costas discriminator (discriminator='atan'): the signal carries data bits")
        if self.pll.ts != TS or self.mm.ts != TS:
            raise ValueError(f"the PLL and MM filter must run at the code period, ts = {TS} s")
        if self.pull_in_ms < self.mm.m2m4_window:
            raise ValueError(f"pull_in_ms ({self.pull_in_ms}) must cover the MM filter's m2m4_window ({self.mm.m2m4_window} epochs)")
        if self.code_passes < 0:
            raise ValueError(f"code_passes must be >= 0 (got {self.code_passes})")
        if self.fine_search_ms < 10:
            raise ValueError(f"fine_search_ms must be >= 10 ms (got {self.fine_search_ms})")


def refine_acquisition(samples: np.ndarray, fs: float, prn: int, acq: Acquisition, n_ms: int, spacing_chips: float = 1.0,
                       code_passes: int = 3, intermediate_frequency_hz: float = 0.0) -> Acquisition:
    """``acq`` with its Doppler and code phase refined on the first ``n_ms`` ms, open loop (module docstring)."""

    def prompts(doppler_hz: float, code_phase: float, n: int, spacing: float | None = None):
        return correlate(samples, fs, prn, code_phase, doppler_hz, 0.0, n, spacing, intermediate_frequency_hz=intermediate_frequency_hz)

    n_fft = 1 << 16
    code = acq.code_phase_chips
    y = prompts(acq.doppler_hz, code, n_ms).prompt
    f2 = fft.fftfreq(n_fft, d=TS)[int(np.argmax(np.abs(fft.fft(y**2, n_fft))))]  # twice the residual, in [-500, 500) Hz
    candidates = acq.doppler_hz + f2 / 2.0 + np.array([-500.0, 0.0, 500.0])
    power = [np.mean(np.abs(prompts(f, code, min(n_ms, 20)).prompt) ** 2) for f in candidates]
    doppler = float(candidates[int(np.argmax(power))])
    gain = dll.discriminator_gain(spacing_chips)
    for _ in range(code_passes):
        c = prompts(doppler, code, n_ms, spacing_chips)
        dtau = dll.discriminator(np.mean(np.abs(c.early)), 0.0, np.mean(np.abs(c.late)), 0.0, gain)  # replica minus received (chips)
        code = float(np.mod(code - dtau, CHIPS))
    return replace(acq, code_phase_chips=code, doppler_hz=doppler)


class _Dll:
    """Carrier-aided first-order DLL on 1-ms E/L: :mod:`scintrack.navigation.dll`'s discriminator and loop gain."""

    def __init__(self, bandwidth_hz: float, spacing_chips: float):
        self.k = dll.loop_gain(bandwidth_hz, TS) / TS
        self.gain = dll.discriminator_gain(spacing_chips)

    def discriminator(self, c: PeriodCorrelation) -> float:
        return dll.discriminator(c.early.real, c.early.imag, c.late.real, c.late.imag, self.gain)

    def code_rate(self, carrier_freq_hz: float, d: float) -> float:
        """``1.023e6 (1 + f / f_L1) - K D`` (chips/s) for the next period."""
        return float(code_rate_hz(carrier_freq_hz)) - self.k * d


class _PllChannel:
    """The Costas PLL closed through a correlator: per epoch :func:`.blocks.atan_discriminator` and :func:`.blocks.pll_step`."""

    def __init__(self, corr: SampleCorrelator, pll: PLL, dll_: _Dll, doppler_hz: float, t0: float):
        self.corr, self.dll = corr, dll_
        self.gains = blocks.pll_constants(pll.bandwidth_hz, TS)
        self.rate = float(code_rate_hz(doppler_hz))
        first = corr.clone().correlate(self.rate, doppler_hz, 0.0, t0).prompt  # the first period at phase 0
        self.psi, self.v, self.w = blocks.atan_discriminator(first.real, first.imag, 0.0), 2.0 * np.pi * doppler_hz, 0.0

    def step(self, t: float) -> dict | None:
        """Correlate the epoch whose nominal mid-time is ``t``, update the loops; None past the samples."""
        if not self.corr.fits(self.rate):
            return None
        psi, v, w, rate = self.psi, self.v, self.w, self.rate
        c = self.corr.correlate(rate, v / (2.0 * np.pi), psi, t)
        y = c.prompt * np.exp(1j * psi)  # the prompt in the loop's phase frame
        e = blocks.atan_discriminator(y.real, y.imag, psi)
        self.psi, self.v, self.w = blocks.pll_step(psi, v, w, e, *self.gains, TS)
        d = self.dll.discriminator(c)
        self.rate = self.dll.code_rate(self.v / (2.0 * np.pi), d)
        return {"early": c.early, "prompt": c.prompt, "late": c.late, "pll_observation": y, "pll_phase_error": e,
                "pll_nco_phase": psi, "carrier_frequency": v / (2.0 * np.pi), "carrier_rate": w / (2.0 * np.pi), "code_rate": rate,
                "dll_discriminator": d, "start_time": self.corr.time(c.start), "code_phase": c.code_phase_chips}


class _MmChannel:
    """The MM filter closed through a correlator, run one epoch at a time by :func:`mm_kf_loop`.

    Each call resumes the compiled loop at epoch ``j`` from the posterior of epoch ``j - 1``
    (``start = j``), so the filter's numbers are those of one run over the observations.  The
    state is relative to the reference carrier ``phase_ref + 2 pi f_ref (t - t_ref)``.
    """

    def __init__(self, corr: SampleCorrelator, mm: MMKF, dll_: _Dll, rate: float, n_epochs: int, seed_prompts: np.ndarray,
                 phase_ref: float, f_ref: float, t_ref: float):
        self.corr, self.dll, self.rate = corr, dll_, rate
        self.phase_ref, self.f_ref, self.t_ref = phase_ref, f_ref, t_ref
        self.y = np.zeros((1, n_epochs), dtype=complex)
        seed = np.zeros((1, n_epochs), dtype=complex)
        seed[0, : seed_prompts.size] = seed_prompts
        self.prm = mm.params(seed, mm_init(n_epochs))
        self.out = {name: np.full((1, n_epochs), np.nan) for name in ("theta", "freq", "amp", "p_plus", "log_odds", "cn0")}
        self.cov = np.zeros((1, n_epochs, len(COV_ENTRIES)))
        self.fail = np.full(1, -1, dtype=np.int64)
        self.F = mm.transition()
        self.j = 0

    def step(self, t: float) -> dict | None:
        j = self.j
        if j >= self.y.shape[1] or not self.corr.fits(self.rate):
            return None
        if j == 0:
            x = self.prm.x0[0]
        else:
            x = self.F @ np.array([self.out["amp"][0, j - 1], self.out["theta"][0, j - 1], self.out["freq"][0, j - 1]])
        phi, f = float(x[1]), float(x[2])  # the prediction for this epoch sets the NCO
        ref = self.phase_ref + 2.0 * np.pi * self.f_ref * (t - self.t_ref)
        c = self.corr.correlate(self.rate, self.f_ref + f, ref + phi, t)
        y = c.prompt * np.exp(1j * phi)  # the prompt in the filter's (reference-relative) phase frame
        self.y[0, j] = y
        n = j + 1
        mm_kf_loop(self.y[:, :n], self.prm, np.array([j], dtype=np.int64), *(v[:, :n] for v in self.out.values()), self.cov[:, :n], self.fail)
        f_post = self.f_ref + self.out["freq"][0, j]
        self.rate = self.dll.code_rate(f_post, self.dll.discriminator(c))
        self.j += 1
        return {"mm_prompt": c.prompt, "mm_observation": y, "mm_phase_error": blocks.atan_discriminator(c.prompt.real, c.prompt.imag, 0.0),
                "mm_phase": self.out["theta"][0, j], "mm_carrier_frequency": f_post}


def mm_init(n_epochs: int) -> TrackInit:
    """The MM channel's initial state (on the reference carrier: phase 0, frequency 0) and bit priors (1/2: no prediction)."""
    return TrackInit(phase=np.zeros(1), doppler_hz=np.zeros(1), rate_hz_s=np.zeros(1), bit_prior=np.full(n_epochs, 0.5))


COMPLEX_OUTPUTS = ("early", "prompt", "late", "pll_observation", "mm_prompt", "mm_observation")
REAL_OUTPUTS = ("start_time", "code_phase", "pll_phase_error", "pll_nco_phase", "carrier_frequency", "carrier_rate", "code_rate", "dll_discriminator",
                "mm_phase_error", "mm_phase", "mm_carrier_frequency", "cn0")


def track_satellite(samples: np.ndarray, fs: float, prn: int, acq: Acquisition, settings: TrackingSettings = TrackingSettings(),
                    n_epochs: int | None = None, intermediate_frequency_hz: float = 0.0) -> xr.Dataset:
    """Both channels of one satellite over ``n_epochs`` code periods (default: as many as the samples hold)."""
    s = settings
    samples = np.asarray(samples)
    fine = refine_acquisition(samples, fs, prn, acq, s.fine_search_ms, s.spacing_chips, s.code_passes, intermediate_frequency_hz)
    doppler = fine.doppler_hz
    corr = SampleCorrelator(samples, fs, prn, fine.code_phase_chips, code_rate_hz(doppler), spacing_chips=s.spacing_chips,
                            intermediate_frequency_hz=intermediate_frequency_hz)
    if n_epochs is None:
        n_epochs = int((samples.size - corr.start) / (fs * TS)) - 1
    t0 = corr.time(corr.start + 0.5 * (corr.period_samples(code_rate_hz(doppler)) - 1))  # mid-time of epoch 0
    dll_ = _Dll(s.dll_bandwidth_hz, s.spacing_chips)
    pll = _PllChannel(corr, s.pll, dll_, doppler, t0)
    mm = None
    cn0 = StreamingM2M4(1, s.cn0_window_ms, prior_signal=np.nan, prior_noise=np.nan)
    out = {name: np.full(n_epochs, np.nan, dtype=complex) for name in COMPLEX_OUTPUTS}
    out.update({name: np.full(n_epochs, np.nan) for name in REAL_OUTPUTS})
    k0 = s.pull_in_ms
    for i in range(n_epochs):
        t = t0 + i * TS
        if i == k0:  # hand-over: the MM channel starts from the PLL channel's NCOs and takes its noise prior
            mm = _MmChannel(corr.clone(), s.mm, dll_, pll.rate, n_epochs - k0, out["prompt"][k0 - s.mm.m2m4_window : k0],
                            pll.psi, pll.v / (2.0 * np.pi), t)
        row = pll.step(t)
        if row is None:
            break
        sig, noi = cn0.update(np.array([row["prompt"]]))
        row["cn0"] = to_dbhz(cn0_from_powers(sig, noi, TS))[0]
        if mm is not None:
            row.update(mm.step(t) or {})
        for name, value in row.items():
            if name in out:
                out[name][i] = value
    locked = lock_state(np.nan_to_num(out["pll_phase_error"], nan=np.pi / 2), TS, s.lock_threshold_rad, s.lock_window_s)
    return _dataset(prn, out, locked, acq, fine, s, t0)


def _dataset(prn: int, out: dict, locked: np.ndarray, acq: Acquisition, fine: Acquisition, s: TrackingSettings, t0: float) -> xr.Dataset:
    n = locked.size
    epoch = np.arange(n)
    ds = xr.Dataset(coords={"epoch": ("epoch", epoch, {"long_name": "code period index from the first code epoch of the recording"})})
    ds["time"] = ("epoch", t0 + epoch * TS, {"long_name": "nominal mid-time of the code period (the loops' epoch time)", "units": "s"})
    ds["start_time"] = ("epoch", out["start_time"], {"long_name": "time of the first sample of the code period", "units": "s"})
    ds["pll_observation_i"] = ("epoch", out["pll_observation"].real, {"long_name": "PLL prompt in the loop's phase frame, P exp(j psi), in-phase"})
    ds["pll_observation_q"] = ("epoch", out["pll_observation"].imag, {"long_name": "PLL prompt in the loop's phase frame, quadrature"})
    for name in ("early", "prompt", "late"):
        ds[f"{name}_i"] = ("epoch", out[name].real, {"long_name": f"{name} in-phase correlation of the PLL channel (sample mean)"})
        ds[f"{name}_q"] = ("epoch", out[name].imag, {"long_name": f"{name} quadrature correlation of the PLL channel (sample mean)"})
    ds["pll_phase_error"] = ("epoch", out["pll_phase_error"], {"long_name": "Costas discriminator output of the PLL", "units": "rad"})
    ds["pll_nco_phase"] = ("epoch", out["pll_nco_phase"], {"long_name": "PLL NCO carrier phase at the epoch's nominal mid-time", "units": "rad"})
    ds["carrier_frequency"] = ("epoch", out["carrier_frequency"], {"long_name": "PLL carrier frequency (Doppler + receiver clock)", "units": "Hz"})
    ds["carrier_rate"] = ("epoch", out["carrier_rate"], {"long_name": "PLL frequency-rate state w / 2 pi", "units": "Hz s-1"})
    ds["code_phase"] = ("epoch", out["code_phase"], {"long_name": "PLL channel replica code phase at the period's first sample", "units": "chip"})
    ds["code_rate"] = ("epoch", out["code_rate"], {"long_name": "PLL channel replica code rate", "units": "chip s-1"})
    ds["dll_discriminator"] = ("epoch", out["dll_discriminator"], {"long_name": "PLL channel DLL discriminator", "units": "chip"})
    ds["mm_prompt_i"] = ("epoch", out["mm_prompt"].real, {"long_name": "prompt in-phase correlation of the MM channel"})
    ds["mm_prompt_q"] = ("epoch", out["mm_prompt"].imag, {"long_name": "prompt quadrature correlation of the MM channel"})
    ds["mm_observation_i"] = ("epoch", out["mm_observation"].real, {"long_name": "MM channel prompt in the filter's phase frame, in-phase"})
    ds["mm_observation_q"] = ("epoch", out["mm_observation"].imag, {"long_name": "MM channel prompt in the filter's phase frame, quadrature"})
    ds["mm_phase"] = ("epoch", out["mm_phase"], {"long_name": "MM filter posterior phase relative to the reference carrier", "units": "rad"})
    ds["mm_phase_error"] = ("epoch", out["mm_phase_error"], {"long_name": "Costas phase of the MM channel's prompt against its NCO", "units": "rad"})
    ds["mm_carrier_frequency"] = ("epoch", out["mm_carrier_frequency"], {"long_name": "MM filter carrier frequency (posterior)", "units": "Hz"})
    ds["cn0"] = ("epoch", out["cn0"], {"long_name": f"C/N0 of the PLL prompts, sliding M2M4 over {s.cn0_window_ms} ms", "units": "dB-Hz"})
    ds["locked"] = ("epoch", locked, {"long_name": f"lock detector: mean |PLL phase error| over {s.lock_window_s} s <= {s.lock_threshold_rad} rad"})
    ds.attrs.update({"prn": int(prn), "acquisition_doppler_hz": acq.doppler_hz, "acquisition_code_phase_chips": acq.code_phase_chips,
                     "acquisition_peak_ratio": acq.peak_ratio, "refined_doppler_hz": fine.doppler_hz,
                     "refined_code_phase_chips": fine.code_phase_chips, "pull_in_ms": s.pull_in_ms,
                     "pll_bandwidth_hz": s.pll.bandwidth_hz,
                     "dll_bandwidth_hz": s.dll_bandwidth_hz, "spacing_chips": s.spacing_chips})
    return ds


def track_recording(samples: np.ndarray, fs: float, acquisitions: Mapping[int, Acquisition], settings: TrackingSettings = TrackingSettings(),
                    n_epochs: int | None = None, intermediate_frequency_hz: float = 0.0) -> xr.Dataset:
    """:func:`track_satellite` for every PRN of ``acquisitions``, stacked over ``prn`` (common epoch count)."""
    samples = np.asarray(samples)
    if n_epochs is None:
        n_epochs = int(samples.size / (fs * TS)) - 2  # every satellite's periods fit, whatever its first code epoch
    tracks = [track_satellite(samples, fs, prn, acq, settings, n_epochs, intermediate_frequency_hz) for prn, acq in acquisitions.items()]
    ds = xr.concat([t.assign_coords(prn=t.attrs["prn"]) for t in tracks], dim="prn", combine_attrs="drop_conflicts")
    for name in ("acquisition_doppler_hz", "acquisition_code_phase_chips", "acquisition_peak_ratio", "refined_doppler_hz", "refined_code_phase_chips"):
        ds[name] = ("prn", [t.attrs[name] for t in tracks])
        ds.attrs.pop(name, None)
    ds.attrs.pop("prn", None)
    return ds


def summary(ds: xr.Dataset, pull_in_ms: int | None = None) -> xr.Dataset:
    """One row per satellite over the epochs after the pull-in (module docstring)."""
    if "prn" not in ds.dims:
        ds = ds.expand_dims(prn=[ds.attrs["prn"]])
    k0 = int(ds.attrs["pull_in_ms"] if pull_in_ms is None else pull_in_ms)
    rows = {key: [] for key in ("cn0", "lock", "offset", "edge_ms", "n_edges", "confidence", "pll_std", "mm_std")}
    for prn in ds["prn"].values:
        one = ds.sel(prn=prn)
        after = one.isel(epoch=slice(k0, None))
        valid = np.isfinite(after["pll_phase_error"].values)
        after = after.isel(epoch=np.flatnonzero(valid))
        prompt = after["prompt_i"].values + 1j * after["prompt_q"].values
        sync = bitsync.bit_sync(prompt)
        rows["cn0"].append(float(np.nanmean(after["cn0"].values)))
        rows["lock"].append(float(np.mean(after["locked"].values)))
        rows["offset"].append(-1 if sync.offset is None else int((sync.offset + k0) % bitsync.BIT_MS))
        edge_ms = np.nan if sync.offset is None else float(np.mod(after["start_time"].values[sync.boundaries[0]] / TS, bitsync.BIT_MS))
        rows["edge_ms"].append(edge_ms)
        rows["n_edges"].append(int(sync.edges.size))
        rows["confidence"].append(sync.confidence)
        rows["pll_std"].append(float(np.nanstd(after["pll_phase_error"].values)))
        rows["mm_std"].append(float(np.nanstd(after["mm_phase_error"].values)))
    attrs = {
        "cn0": ("mean_cn0_dbhz", {"long_name": "mean C/N0 after pull-in (M2M4)", "units": "dB-Hz"}),
        "lock": ("lock_fraction", {"long_name": "fraction of epochs after pull-in in lock (lock detector)"}),
        "offset": ("bit_edge_epoch_mod20", {"long_name": "epoch index modulo 20 of the bit edges (-1: no sign change)"}),
        "edge_ms": ("bit_edge_ms_mod20", {"long_name": "start time of the bit-edge code periods modulo 20 ms, from sample 0", "units": "ms"}),
        "n_edges": ("n_bit_edges", {"long_name": "data transitions seen on the bit-edge offset after pull-in"}),
        "confidence": ("edge_fraction", {"long_name": "fraction of prompt sign changes after pull-in on the bit-edge offset"}),
        "pll_std": ("pll_phase_error_std", {"long_name": "std of the PLL Costas phase error after pull-in", "units": "rad"}),
        "mm_std": ("mm_phase_error_std", {"long_name": "std of the MM channel's Costas phase error after pull-in", "units": "rad"}),
    }
    out = xr.Dataset(coords={"prn": ds["prn"].values})
    for key, (name, a) in attrs.items():
        out[name] = ("prn", np.asarray(rows[key]), a)
    out.attrs["pull_in_ms"] = k0
    return out


def summary_markdown(table: xr.Dataset, digits: int = 2) -> str:
    """The summary as a Markdown table: counts as integers, the bit-edge time to 1 us, the rest to ``digits`` decimals."""
    frame = table.to_dataframe().reset_index()
    fmt = tuple(".0f" if np.issubdtype(frame[c].dtype, np.integer) else ".3f" if c == "bit_edge_ms_mod20" else f".{digits}f" for c in frame.columns)
    return frame.to_markdown(index=False, floatfmt=fmt)


__all__ = ["TrackingSettings", "refine_acquisition", "summary", "summary_markdown", "track_recording", "track_satellite"]
