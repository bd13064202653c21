"""The jamming receiver of Zhao et al. on the jammed GPS dataset: one satellite channel, Monte Carlo over noise.

Per satellite and batch of trials (noise realisations of the same scenario):

1. prompts at 1 ms (:mod:`.gps_prompts`: residual phase after the
   ephemeris-predicted Doppler, seeded E/P/L noise);
2. the baseline: a third-order Costas PLL at 1 ms (``zhao_receiver.pll``);
   its phase error is ambiguous by pi, so it is reported modulo pi;
   with ``zhao_receiver.pll_lock`` also the same PLL as a receiver runs it
   (variant ``pll_fll``: lock detector, frequency hold, FLL-assisted re-pull;
   :mod:`scintrack.trackers.pll_lock`);
3. the MM Kalman filter (``zhao_receiver.mm``) on bit-synchronous 20-ms sums,
   once per bit-prior strategy (``variants``):

   * ``mm_none``: every bit 1/2;
   * ``mm_mask``: the upload-robust mask
     (:func:`scintrack.signals.gps.bit_prediction.robust_prediction`);
   * ``mm_iode``: the IODE check on the filter's OWN decisions, frame by
     frame (:class:`~scintrack.signals.gps.bit_prediction.BitPredictor`), so
     wrong decisions and an upload during jamming give wrong predictions.
     The priors of frame j+1 depend on the decisions of frames <= j, and the
     filter is causal, so the sequential receiver is computed exactly by
     re-running the filter over the whole span with the priors of the last
     decisions until the decisions stop changing (a fixed point of a causal
     chain is the sequential solution);

   the MM phase error is wrapped to (-pi, pi]: a half-cycle slip (the bit
   ambiguity resolved the wrong way) counts as an error of pi;
4. a carrier-aided DLL (:mod:`scintrack.navigation.dll`) on the same noise
   draws' E/L columns, aided by each carrier tracker's frequency estimate, for
   the pseudoranges of the positioning step (:mod:`.gps_positioning`);
   ``dll.carrier_aiding: false`` gives the loop without aiding (its NCO
   holds the hand-over Doppler), which receivers use when the carrier loop
   is not trusted.

Bit synchronisation and the navigation history before the start (the frames
a receiver decoded in the clean minutes before, 25 of them for the pages)
are taken as known: the receiver has been tracking at 46 dB-Hz.  The MM
filter and the PLL start at the true residual phase and frequency ("the
receiver is already tracking ... the estimate error is small immediately
prior to the event onset").
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from ..signals.gps import bit_prediction, ephemeris, message
from ..signals.gps.correlator import NoiseStream
from ..trackers import pll_lock
from ..trackers.base import TrackerContext, TrackInit
from ..trackers.registry import build
from . import gps_bit_prediction
from . import gps_prompts as gp
from .metrics import derotated_sums

STREAM = "zhao_jamming/receiver"
FRAME_BITS = 1500
MAX_FIXED_POINT_ITERATIONS = 40


def decoded_ephemeris(ds: xr.Dataset, k: int) -> ephemeris.Ephemeris:
    """The data set a receiver decoded from the last complete frame before the scenario start (clean history)."""
    bits = ds["nav_bits"].isel(sv=k).values
    t = ds["nav_bit_time"].values
    before = bits[t < 0.0]
    subframes = [s for s in message.decode_message(before) if s.ok and s.subframe_id in (1, 2, 3)]
    fields: dict[str, float] = {}
    for sf in (1, 2, 3):
        last = [s for s in subframes if s.subframe_id == sf]
        if not last:
            raise ValueError(f"PRN {int(ds['prn'][k])}: no decodable subframe {sf} before the start; raise gps_jamming.message_lead_s")
        fields.update({key: float(v) for key, v in last[-1].fields.items()})
    return ephemeris.Ephemeris(prn=int(ds["prn"].values[k]), week=int(ds.attrs["gps_week"]), transmit_time=float(ds.attrs["t_start_sow"]), fit_hours=4.0, fields=fields)


def _tracker(config_trackers: Mapping[str, Any], name: str, ts: float):
    context = TrackerContext(scenario={}, tracking={}, ts=ts)
    return build(name, config_trackers[name], context)


def _frame_layout(ds: xr.Dataset, k: int, start: int, n_bits: int) -> tuple[np.ndarray, int]:
    """Message bit index of each 20-ms sum, and the index of the first frame that starts at/after the scenario start."""
    first_bit = int(ds["nav_bit_of_epoch0"].isel(sv=k)) + (1 if start > 0 else 0)
    idx = first_bit + np.arange(n_bits)
    return idx, int(np.ceil(first_bit / FRAME_BITS))


class PriorSource:
    """Bit priors of one strategy for the 20-ms sums of a channel; the history before the scenario is read once.

    The priors of frame j depend only on the frames decided before it, and
    trials (and the fixed-point iterations of :func:`run_mm`) mostly share
    those, so the predictor state after each distinct sequence of decided
    frames, and the priors it gives the next frame, are computed once per
    channel (``_after``: keyed by the bytes of the decided frames so far;
    ``_next``: by frame index and those bytes; the same predictor calls on
    the same states, so the same bits).
    """

    def __init__(self, strategy: str, robust: bit_prediction.RobustPrediction | None, history: np.ndarray, nav_idx: np.ndarray, eps: float):
        self.strategy, self.robust, self.nav_idx = strategy, robust, nav_idx
        if strategy == "mm_none":
            return
        self.first = int(nav_idx[0] // FRAME_BITS)
        self.last = int(nav_idx[-1] // FRAME_BITS)
        self.base = bit_prediction.BitPredictor(strategy.removeprefix("mm_"), robust, eps=eps)
        for j in range(self.first):  # complete frames decided before the scenario (clean history)
            self.base.observe(history[j * FRAME_BITS : (j + 1) * FRAME_BITS])
        self.head = history[self.first * FRAME_BITS :]  # bits of the first scenario frame before the first sum
        self._after: dict[bytes, bit_prediction.BitPredictor] = {b"": self.base}
        self._next: dict[tuple[int, bytes], np.ndarray] = {}
        self.static = None
        if strategy == "mm_mask":  # the mask does not depend on decisions
            self.static = self._stream(np.zeros(len(nav_idx), dtype=np.int8))

    def _stream(self, decisions: np.ndarray) -> np.ndarray:
        n_frames = self.robust.n_frames
        full = np.full(n_frames * FRAME_BITS, -1, dtype=np.int8)
        full[self.first * FRAME_BITS : self.first * FRAME_BITS + len(self.head)] = self.head
        full[self.nav_idx] = decisions
        stream = np.full(n_frames * FRAME_BITS, 0.5)
        key = b""  # the decided scenario frames observed so far
        for j in range(self.first, self.last + 1):
            predictor = self._after[key]
            priors = self._next.get((j, key))
            if priors is None:
                priors = self._next[(j, key)] = predictor.priors(j)
            stream[j * FRAME_BITS : (j + 1) * FRAME_BITS] = priors
            frame = full[j * FRAME_BITS : (j + 1) * FRAME_BITS]
            if np.all(frame >= 0):
                key += frame.tobytes()
                if key not in self._after:
                    self._after[key] = predictor.fork()
                    self._after[key].observe(frame)
            elif self.strategy == "mm_iode":
                break  # the last, partly decided frame: nothing after it needs priors
        return stream[self.nav_idx]

    def priors(self, decisions: np.ndarray) -> np.ndarray:
        """P(level +1) of each 20-ms sum for one trial, given the filter's decisions (0/1 per sum)."""
        if self.strategy == "mm_none":
            return np.full(len(self.nav_idx), 0.5)
        if self.static is not None:
            return self.static
        return self._stream(decisions)


def held_1ms(values: np.ndarray, start: int, n_epochs: int) -> np.ndarray:
    """Per-sum values (trials, sums) of the 20-ms sums starting at epoch ``start``, held over their 1-ms epochs,
    and the first and last held before and after them: (trials, n_epochs), written once (the values of
    ``numpy.pad(numpy.repeat(values, 20, axis=1), ..., mode="edge")`` without its intermediate array)."""
    n_tr, n_bits = values.shape
    end = start + n_bits * gp.BIT_MS
    out = np.empty((n_tr, n_epochs))
    out[:, start:end].reshape(n_tr, n_bits, gp.BIT_MS)[...] = values[:, :, None]
    out[:, :start] = values[:, :1]
    out[:, end:] = values[:, -1:]
    return out


def run_mm(tracker, y20: np.ndarray, init: TrackInit, source: PriorSource):
    """The MM filter with the bit priors of ``source``; for ``mm_iode`` iterated to the sequential fixed point.

    Each iteration after the first resumes the previous one (``tracker.resume``, when the tracker has it,
    as :class:`~scintrack.trackers.mm_kf.MMKF` does): a trial is filtered again only from the first sum
    whose prior changed, with the bits of a run over the whole span (the iterations change the priors
    from a frame 14-225 s into the 240-s span, so ~60 % of a whole rerun would be a repeat).
    """
    strategy = source.strategy
    trials = y20.shape[0]
    iterate = strategy == "mm_iode"
    resume = getattr(tracker, "resume", None) if iterate else None
    decisions = np.zeros((trials, y20.shape[1]), dtype=np.int8)
    priors = np.stack([source.priors(decisions[t]) for t in range(trials)])
    out = previous = None
    for _ in range(MAX_FIXED_POINT_ITERATIONS if iterate else 1):
        step = TrackInit(phase=init.phase, doppler_hz=init.doppler_hz, rate_hz_s=init.rate_hz_s, bit_prior=priors)
        if resume is None:
            out = tracker.run(y20, step)
        elif out is None:
            out = tracker.run(y20, step, keep_covariance=True)
        else:
            out = resume(y20, step, out, previous)
        new = (out.extras["p_plus"] < 0.5).astype(np.int8)  # level -1 = bit 1
        if not iterate or np.array_equal(new, decisions):
            decisions = new
            break
        decisions = new
        previous, priors = priors, np.stack([source.priors(decisions[t]) for t in range(trials)])
    else:
        raise RuntimeError("IODE-check receiver did not reach its sequential fixed point")
    out.extras.pop("covariance", None)
    return out, priors, decisions


def prior_sources(ds: xr.Dataset, k: int, variants: Sequence[str], ephs: Sequence[ephemeris.Ephemeris], header: ephemeris.NavHeader,
                  eps: float, robust: bit_prediction.RobustPrediction | None = None) -> dict[str, PriorSource]:
    """The bit-prior source of each MM variant for satellite ``k`` (the upload-robust prediction is computed once).

    ``robust``: that prediction, already computed (:mod:`.gps_bit_prediction`, the rule
    ``zhao_bit_prediction``); by default it is computed here when a variant needs it.
    """
    start = (gp.BIT_MS - int(ds["first_epoch_in_bit"].isel(sv=k))) % gp.BIT_MS
    n_bits = (ds.sizes["epoch"] - start) // gp.BIT_MS
    nav_idx, _ = _frame_layout(ds, k, start, n_bits)
    history = np.zeros(0, dtype=np.int8)
    if any(v != "mm_none" for v in variants):
        if robust is None:
            robust = gps_bit_prediction.channel_prediction(ds, k, ephs, header)
        elif robust.prn != int(ds["prn"].values[k]):
            raise ValueError(f"the bit prediction given is for PRN {robust.prn}, the channel is PRN {int(ds['prn'].values[k])}")
        history = ds["nav_bits"].isel(sv=k).values[: nav_idx[0]]
    else:
        robust = None
    return {v: PriorSource(v, robust, history, nav_idx, eps) for v in variants}


def pll_fll_outputs(pll, y1: np.ndarray, init1: TrackInit, start: int, n_bits: int, rc: Mapping[str, Any], phi: np.ndarray,
                    f_res: np.ndarray, code_error) -> dict[str, np.ndarray]:
    """The ``pll_fll`` variant: the PLL ``pll`` with lock detector, frequency hold and FLL re-pull
    (:mod:`scintrack.trackers.pll_lock`, ``zhao_receiver.pll_lock`` with the detector of ``zhao_receiver.lock``),
    on the same prompts; its outputs under the PLL's names with the prefix ``pll_fll_`` (errors modulo pi,
    Costas), and ``pll_fll_locked``: its own detector's state at each bit."""
    o = pll_lock.run(pll, y1, init1, start, pll_lock.settings(rc["pll_lock"], rc["lock"]))
    phase, freq = o.theta_d, o.extras["frequency_hz"]
    sl = slice(start, start + n_bits * gp.BIT_MS, gp.BIT_MS)
    rot = derotated_sums(y1, phase, gp.BIT_MS, start, n_bits)
    res = {
        "pll_fll_phase_error": gp.wrap(phase[:, sl] - phi[sl], np.pi),
        "pll_fll_frequency_error": freq[:, sl] - f_res[sl],
        "pll_fll_level": np.sign(rot.real).astype(np.int8),
        "pll_fll_locked": o.extras["locked"][:, sl],
    }
    del o, rot
    res["pll_fll_code_error_chips"] = code_error(phase, freq)
    return res


def channel(ds: xr.Dataset, k: int, params: Mapping[str, Any], trials: Sequence[int], sources: Mapping[str, PriorSource],
            cn0_jammed_dbhz: float | None = None) -> dict[str, np.ndarray]:
    """All trackers of satellite ``k`` for ``trials``; arrays (trials, bits) at 20 ms unless named otherwise."""
    from ..navigation import dll

    rc = params["receiver"]
    stream = NoiseStream(int(params["seed"]), STREAM, float(rc["dll"]["spacing_chips"]))
    eph = decoded_ephemeris(ds, k)
    phi, f_res = gp.residual_phase(ds, k, eph)
    cn0 = ds["cn0"].isel(sv=k).values.astype(float)
    if cn0_jammed_dbhz is not None:
        cn0 = np.where(ds["receive_time"].isel(sv=k).values >= float(ds.attrs["jammer_onset_s"]), cn0_jammed_dbhz, cn0)
    bits = ds["bit"].isel(sv=k).values.astype(float)
    y1, noise, sigma = gp.prompts_1ms(stream, trials, k, phi, cn0, bits, float(ds.attrs["cn0_clean_dbhz"]))
    n_tr = len(trials)
    first_in_bit = int(ds["first_epoch_in_bit"].isel(sv=k))
    spacing = float(rc["dll"]["spacing_chips"])
    # ``dll.carrier_aiding: false``: the code NCO holds the Doppler of the hand-over (the truth at the start,
    # where the carrier trackers start too) and the loop's own rate correction follows the rest
    # (:func:`scintrack.navigation.dll.run`, ``aiding_error_hz``)
    doppler = ds["doppler"].isel(sv=k).values.astype(float)
    aid_err = None if rc["dll"].get("carrier_aiding", True) else doppler[0] - doppler

    def code_error(phase1: np.ndarray, freq1: np.ndarray) -> np.ndarray:
        """DLL of one carrier tracker on the E/L columns of the same noise draws (phase/frequency at 1 ms).

        Consumes its arguments: the errors are computed in their memory (the same subtraction, without two
        new (trials, epochs) arrays and their page faults per call)."""
        phase_err, freq_err = np.subtract(phase1, phi, out=phase1), np.subtract(freq1, f_res, out=freq1)
        return dll.run(noise, cn0, bits, phase_err, freq_err, spacing_chips=spacing,
                       bandwidth_hz=float(rc["dll"]["bandwidth_hz"]), integration_ms=int(rc["dll"]["integration_ms"]),
                       first_in_bit=first_in_bit, gain="fixed", cn0_ref_dbhz=float(ds.attrs["cn0_clean_dbhz"]),
                       aiding_error_hz=aid_err)

    # Each tracker's DLL runs as soon as its carrier estimates exist, and the 1-ms arrays behind it are
    # dropped, so at most one tracker's (trials, epochs) intermediates are held at a time (peak memory
    # of the job); the arithmetic is the same as running every DLL at the end.
    pll = _tracker(params["trackers"], rc["pll"], gp.CODE_PERIOD_S)
    init1 = TrackInit(phase=np.full(n_tr, phi[0]), doppler_hz=np.full(n_tr, f_res[0]), rate_hz_s=np.zeros(n_tr))
    p_out = pll.run(y1, init1)
    y20, start = gp.bit_sums(y1, first_in_bit)
    n_bits = y20.shape[1]
    phi20 = gp.interval_phase(phi, start, n_bits)
    f20 = f_res[start : start + n_bits * gp.BIT_MS].reshape(n_bits, gp.BIT_MS).mean(axis=1)
    sl = slice(start, start + n_bits * gp.BIT_MS, gp.BIT_MS)
    p_phase, p_freq = p_out.theta_d, p_out.extras["frequency_hz"]
    del p_out
    out: dict[str, np.ndarray] = {
        "pll_phase_error": gp.wrap(p_phase[:, sl] - phi[sl], np.pi),
        "pll_frequency_error": p_freq[:, sl] - f_res[sl],
        "true_frequency": f20,
        "true_level": bits[start : start + n_bits * gp.BIT_MS : gp.BIT_MS],
    }
    # PLL bit decisions (Costas: up to a global sign) for the clean-segment decoding check
    rot = derotated_sums(y1, p_phase, gp.BIT_MS, start, n_bits)
    out["pll_level"] = np.sign(rot.real).astype(np.int8)
    if rc.get("pll_lock") is not None:  # the PLL as a receiver runs it (zhao_receiver.pll_lock)
        out.update(pll_fll_outputs(pll, y1, init1, start, n_bits, rc, phi, f_res, code_error))
    del y1, rot
    out["pll_code_error_chips"] = code_error(p_phase, p_freq)
    del p_phase, p_freq

    mm = _tracker(params["trackers"], rc["mm"], gp.BIT_MS * gp.CODE_PERIOD_S)
    init20 = TrackInit(phase=np.full(n_tr, phi20[0]), doppler_hz=np.full(n_tr, f20[0]), rate_hz_s=np.zeros(n_tr))
    n_epochs = len(phi)
    for variant in rc["variants"]:
        m_out, priors, decisions = run_mm(mm, y20, init20, sources[variant])
        out[f"{variant}_phase_error"] = gp.wrap(m_out.theta_d - phi20[None, :])
        out[f"{variant}_frequency_error"] = m_out.extras["frequency_hz"] - f20[None, :]
        true_bit = (out["true_level"] < 0).astype(np.int8)
        out[f"{variant}_bit_error"] = decisions != true_bit[None, :]
        out[f"{variant}_predicted"] = np.abs(priors - 0.5) > 0.25
        out[f"{variant}_prediction_wrong"] = out[f"{variant}_predicted"] & ((priors > 0.5) != (true_bit[None, :] == 0))
        phase1, freq1 = (held_1ms(v, start, n_epochs) for v in (m_out.theta_d, m_out.extras["frequency_hz"]))
        del m_out
        out[f"{variant}_code_error_chips"] = code_error(phase1, freq1)
        del phase1, freq1
    out["start_epoch"] = np.array(start)
    return out
