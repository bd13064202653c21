"""Navigation-data bit prediction for the MM Kalman filter: bit priors per LNAV frame.

Zhao, Khanafseh & Pervan, Sec. III ("Navigation data bit prediction", Fig. 4);
notes ``gps-lnav-mm.md`` Sec. 1.3-1.5.  The MM filter takes, for every 20-ms
bit, the prior probability that the transmitted level is +1 (level
``d = 1 - 2 bit``, so level +1 is bit 0).  Three strategies:

* ``"none"``: 1/2 for every bit (the paper's Sec. II baseline).
* ``"mask"`` -- the paper's *upload-robust partial prediction*
  (:func:`robust_prediction`).  The paper lists the bits that stayed the same
  through cutovers and uploads in several days of data; here the list is
  **derived from the encoder**: the stream of the scenario is encoded under
  many alternative data-set histories and a transmitted bit is predictable
  exactly when it has the same value in all of them.  Alternatives: (1) the
  scheduled stream (:class:`message.Schedule`, no upload); (2) every data set
  of that PRN in the navigation file (regular even-hour sets *and* the
  control segment's own hh:59:44 upload sets) sent throughout the span
  instead; (3) one synthetic upload (:class:`message.Upload`, a
  :func:`message.rereference` of the set in force with a fresh IODC/IODE)
  cut in at each frame boundary of the span, each also with the
  complementary IODE label (:func:`relabel_upload`: the IODE is an arbitrary
  label, and one day's labels all lie below 128, which would otherwise pass
  their MSB for predictable); (4) optionally other subframe 4/5
  page data (``page_alternatives``, e.g. :func:`almanac_update_pages`).
  Mixed histories (one set in some frames, another in others) need not be
  enumerated: the solved bits 293-294 force D29 = D30 = 0 at the end of every
  subframe (IS-GPS-200 Sec. 20.3.5), so the parity chain restarts at every
  subframe and a subframe's transmitted bits depend only on its own content
  (checked: the streams here are chained end to end like
  :func:`message.build_message` and equal it).  What comes out is the
  preamble, TLM, HOW (TOW and subframe ID are functions of time), parity and
  polarity that these fix, every SF1-3 bit the file's sets share *and* that
  the parity chain does not scramble, and the SF4/5 pages.
* ``"iode"`` -- the paper's *IODE check* (:class:`BitPredictor`).  From the
  receiver's own hard decisions of the last complete frame, decode the three
  copies (SF1 IODC 8 LSBs, bits 211-218; SF2 IODE, 61-68; SF3 IODE, 271-278;
  each subframe decoded with :func:`lnav.decode_subframe`, chain started from
  D29* = D30* = 0, which the spec guarantees); if they agree with each other
  and with the last stored IODE (that of the latest earlier frame whose three
  copies agreed), predict the whole next frame (:func:`predict_next_frame`):
  subframes 1-3 re-encoded from the stored decoded content with the new HOW
  TOW and subframe ID and the parity chain, subframes 4-5 re-encoded from the
  page received 25 frames (12.5 min) earlier.  Otherwise (an upload, a
  cutover, or a decision error in an IODE copy) the next frame gets the mask.
  The IODE is checked only once per frame, after it has been received; an
  upload cut in at the next frame boundary is therefore predicted with the
  old set's bits, wrong wherever the two sets' transmitted bits differ.

Choices the paper leaves open, with reasons:

* Predicted bits get prior ``1 - eps`` (default ``eps = 1e-3``) for the
  predicted level, not the paper's 1: a log prior of about 6.9 keeps the
  posterior finite, so a wrong prediction (an undetected upload) costs a
  strong but not infinite penalty and the filter can still follow a
  signal that contradicts it over several bits; at the paper's 15 dB-Hz one
  20-ms bit carries a log-likelihood ratio of 4 Eb/N0 ~ 2.5 on average.
* SF4/5 in the mask: by default the page data are those the stream really
  carries, i.e. the receiver has read the whole 12.5-min superframe before
  the event and no almanac update happens during it; every page bit is then
  predictable.  With ``page_alternatives`` (e.g. almanacs of other epochs,
  :func:`almanac_update_pages`) only page bits that survive an almanac update
  are.  Both counts are reported by :func:`predictable_fraction`.
* Content voting (``"iode"``): the stored SF1-3 content is the per-bit
  majority of the decoded frames of the current IODE run (ties: latest
  frame), the page content the majority of the copies 25, 50, ... frames back;
  the IODE copies themselves come from the last frame only.  A decision error
  outside the IODE copies is thus outvoted instead of being predicted forever.
* ``open_iode`` (default False, the paper's "100 %"): when True the 24
  transmitted bits of the three IODE copies keep the mask prior (1/2) in the
  IODE mode so that the filter's decisions there follow the signal, not the
  prediction; with them predicted at 1 - eps the check mostly confirms its
  own prediction and an upload goes unnoticed.
* The 180-degree ambiguity is assumed resolved (the filter starts from clean
  tracking); decisions are the transmitted bits (0/1) as the stream carries
  them.  When the 25-frame page history is missing, the SF4/5 bits of an
  IODE-mode prediction take the mask's priors.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from . import lnav, lnav_pages
from .ephemeris import SECONDS_PER_WEEK, Ephemeris, NavHeader
from .message import FRAME_S, SUBFRAME_S, Schedule, Upload

FRAME_BITS = 1500
SUBFRAMES = 5
PAGE_CYCLE = 25
STRATEGIES = ("none", "mask", "iode")
#: (subframe index 0..4, first subframe bit 1..300) of the three 8-bit IODE copies (SF1 IODC LSBs, SF2, SF3).
IODE_COPIES = ((0, 211), (1, 61), (2, 271))
#: 0-based positions in a 1500-bit frame of the 24 bits of the three IODE copies.
IODE_POSITIONS = np.array([300 * s + first - 1 + k for s, first in IODE_COPIES for k in range(8)])


# ---- stream encoding -------------------------------------------------------------------------------------


def _content_key(fields: Mapping[str, float]) -> tuple:
    return tuple(sorted((k, float(v)) for k, v in fields.items()))


class _Encoder:
    """Subframe encodings cached by (start time, content, incoming D29*/D30*), shared by all alternatives."""

    def __init__(self, week: int):
        self.week = int(week)
        self._cache: dict[tuple, list[int]] = {}

    def subframe(self, t0: int, content: Mapping[str, float] | lnav_pages.PageData, key: tuple, tail: tuple[int, int]) -> list[int]:
        ck = (t0, key, tail)
        out = self._cache.get(ck)
        if out is None:
            if lnav.subframe_id(t0) <= 3:
                src = lnav.source_bits(t0, {**content, "wn": self.week % 1024})
            else:
                src = lnav_pages.page_source_bits(t0, content)
            out = self._cache[ck] = lnav.encode_subframe(src, *tail)
        return out

    def stream(self, frame_fields: Sequence[Mapping[str, float]], pages: lnav_pages.PageData, f0: int) -> np.ndarray:
        """Transmitted bits of consecutive frames from ``f0`` (s of week), frame j carrying ``frame_fields[j]``."""
        page_key = ("pages", id(pages))
        sent: list[int] = []
        tail = (0, 0)
        for j, fields in enumerate(frame_fields):
            key = _content_key(fields)
            for k in range(SUBFRAMES):
                t0 = f0 + FRAME_S * j + SUBFRAME_S * k
                out = self.subframe(t0, fields, key, tail) if k < 3 else self.subframe(t0, pages, page_key, tail)
                tail = (out[-2], out[-1])
                sent += out
        return np.array(sent, dtype=np.int8)


def encode_stream(
    frame_fields: Sequence[Mapping[str, float]], pages: lnav_pages.PageData, week: int, f0: int,
) -> np.ndarray:
    """Transmitted LNAV bits of ``len(frame_fields)`` frames from ``f0`` with the given SF1-3 content per frame.

    Same assembly as :func:`message.build_message` (WN = week of transmission,
    parity chained across the stream) but with any data set in any frame.
    """
    _check_frame_time(f0, "f0")
    if f0 + FRAME_S * len(frame_fields) > SECONDS_PER_WEEK:
        raise ValueError(f"f0 = {f0} with {len(frame_fields)} frames runs past the end of the week; split the span")
    return _Encoder(week).stream(frame_fields, pages, f0)


def _check_frame_time(t: float, name: str) -> None:
    if t % FRAME_S or not 0 <= t < SECONDS_PER_WEEK:
        raise ValueError(f"{name} = {t}: a frame starts at a multiple of 30 s of the week in [0, 604800)")


# ---- strategy (b): upload-robust mask ---------------------------------------------------------------------


@dataclass(frozen=True)
class RobustPrediction:
    """Upload-robust prediction of a scenario stream.

    ``bits``: the scheduled transmitted stream (no upload) from ``t0`` (s of
    ``week``), whole frames; ``mask``: True where every alternative history
    transmits the same bit (so ``bits`` there is the prediction);
    ``n_alternatives``: histories compared.
    """

    prn: int
    week: int
    t0: int
    bits: np.ndarray
    mask: np.ndarray
    n_alternatives: int

    @property
    def n_frames(self) -> int:
        return len(self.bits) // FRAME_BITS

    def frame(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """(bits, mask) of frame ``k`` (0-based from ``t0``)."""
        if not 0 <= k < self.n_frames:
            raise ValueError(f"frame index {k}: the prediction covers frames 0..{self.n_frames - 1}; widen t_start/t_end")
        s = slice(FRAME_BITS * k, FRAME_BITS * (k + 1))
        return self.bits[s], self.mask[s]


def alternative_histories(
    ephemerides: Sequence[Ephemeris], prn: int, week: int, f0: int, n_frames: int, upload_times: Sequence[float] | None = None,
) -> list[list[Mapping[str, float]]]:
    """SF1-3 content per frame of every alternative history (module docstring); the first is the scheduled one.

    ``upload_times`` (s of week): cut-in times of the synthetic uploads; by
    default every frame boundary of the span.
    """
    times = [f0 + FRAME_S * j for j in range(n_frames)]
    base = week * SECONDS_PER_WEEK
    schedule = Schedule(ephemerides, prn, week)
    histories = [[schedule.at(base + t).fields for t in times]]
    sets = sorted((e for e in ephemerides if e.prn == prn), key=lambda e: (e.week, e.t_oc, e.transmit_time))
    histories += [[e.fields] * n_frames for e in sets]
    for t_up in times if upload_times is None else upload_times:
        with_upload = [Schedule(ephemerides, prn, week, [Upload(prn, float(t_up))]).at(base + t) for t in times]
        histories.append([ds.fields for ds in with_upload])
        histories.append([relabel_upload(ds.fields) if ds.kind == "upload" else ds.fields for ds in with_upload])
    return histories


def relabel_upload(fields: Mapping[str, float]) -> dict[str, float]:
    """The same uploaded set with the complementary 8-bit IODE (and IODC LSBs; IODC MSBs kept).

    The IODE is a label (IS-GPS-200 Sec. 20.3.4.4 only forbids reuse within
    6 h), so an upload may carry any value; the complement differs in all 8
    bits, so no IODE bit passes for predictable merely because one day's
    labels happen to share it (all IODEs in brdc2800.15n are below 128).
    """
    iode = 0xFF ^ int(fields["iode"])
    return {**fields, "iode": iode, "iodc": (int(fields["iodc"]) & 0x300) | iode}


def _span_frames(t_start: float, t_end: float) -> tuple[int, int]:
    if not (0 <= t_start < t_end <= SECONDS_PER_WEEK):
        raise ValueError(f"t_start = {t_start}, t_end = {t_end}: need 0 <= t_start < t_end <= 604800 (one week)")
    f0 = FRAME_S * math.floor(t_start / FRAME_S)
    return f0, (FRAME_S * math.ceil(t_end / FRAME_S) - f0) // FRAME_S


def robust_prediction(
    ephemerides: Sequence[Ephemeris],
    header: NavHeader,
    prn: int,
    week: int,
    t_start: float,
    t_end: float,
    *,
    pages: lnav_pages.PageData | None = None,
    page_alternatives: Sequence[lnav_pages.PageData] = (),
    upload_times: Sequence[float] | None = None,
) -> RobustPrediction:
    """Stream of ``prn`` over whole frames covering [t_start, t_end] (s of ``week``) and its upload-robust mask.

    ``pages`` defaults to :func:`lnav_pages.build_page_data` of the same
    file (as :func:`message.build_message`); ``page_alternatives`` are other
    page data the satellite might send instead.
    """
    f0, n = _span_frames(t_start, t_end)
    pages = lnav_pages.build_page_data(ephemerides, header) if pages is None else pages
    histories = alternative_histories(ephemerides, prn, week, f0, n, upload_times)
    enc = _Encoder(week)
    bits = enc.stream(histories[0], pages, f0)
    mask = np.ones(len(bits), dtype=bool)
    for hist in histories[1:]:
        mask &= enc.stream(hist, pages, f0) == bits
    for alt in page_alternatives:
        mask &= enc.stream(histories[0], alt, f0) == bits
    return RobustPrediction(int(prn), int(week), f0, bits, mask, len(histories) + len(page_alternatives))


def robust_mask(
    ephemerides: Sequence[Ephemeris], header: NavHeader, prn: int, week: int, t_start: float, t_end: float, **kwargs,
) -> np.ndarray:
    """Bool per transmitted bit of the scenario stream: True where the bit is the same under every alternative history."""
    return robust_prediction(ephemerides, header, prn, week, t_start, t_end, **kwargs).mask


def predictable_fraction(
    ephemerides: Sequence[Ephemeris], header: NavHeader, prn: int, week: int, t_start: float, n_frames: int = PAGE_CYCLE, **kwargs,
) -> float:
    """Fraction of mask-predictable bits over ``n_frames`` frames from ``t_start`` (default: one 25-page cycle)."""
    if n_frames < 1:
        raise ValueError(f"n_frames = {n_frames}: at least one frame")
    f0 = FRAME_S * math.floor(t_start / FRAME_S)
    mask = robust_mask(ephemerides, header, prn, week, f0, f0 + FRAME_S * n_frames, **kwargs)
    return float(mask.mean())


def almanac_update_pages(
    ephemerides: Sequence[Ephemeris], header: NavHeader, step_s: int = 6 * lnav_pages.T_OA_LSB,
) -> list[lnav_pages.PageData]:
    """Page data with the almanac of other epochs (t_oa every ``step_s`` over the file's t_oe span): an almanac update.

    Health, configuration, iono/UTC and the reserved pages are those of the
    same file; only the almanac content (and t_oa) differs.
    """
    if step_s <= 0 or step_s % lnav_pages.T_OA_LSB:
        raise ValueError(f"step_s = {step_s}: a positive multiple of 4096 s")
    toes = [lnav_pages.reference_times(e)[0] for e in ephemerides]
    if not toes:
        raise ValueError("ephemerides: empty; pass the data sets of a navigation file")
    default = lnav_pages.default_almanac_epoch(ephemerides)
    out = []
    for week in range(int(min(toes) // SECONDS_PER_WEEK), int(max(toes) // SECONDS_PER_WEEK) + 1):
        for t_oa in range(0, 602112 + 1, step_s):  # t_oa is a multiple of 2^12 s of its week
            epoch = (week, t_oa)
            if epoch != default and min(toes) <= week * SECONDS_PER_WEEK + t_oa <= max(toes):
                out.append(lnav_pages.build_page_data(ephemerides, header, almanac_epoch=epoch))
    return out


# ---- strategy (c): IODE check -----------------------------------------------------------------------------


def _frame_array(bits: Sequence[int] | np.ndarray, name: str) -> np.ndarray:
    x = np.asarray(bits)
    if x.shape != (FRAME_BITS,) or not np.isin(x, (0, 1)).all():
        raise ValueError(f"{name}: one frame of 1500 hard-decided bits with values 0/1 (got shape {x.shape})")
    return x.astype(np.int8)


def decode_frame(frame_bits: Sequence[int] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(source bits (1500,), parity verdict per word (50,)) of one decided frame; each subframe chained from D29* = D30* = 0."""
    x = _frame_array(frame_bits, "frame_bits")
    source, ok = [], []
    for s in range(SUBFRAMES):
        src, good = lnav.decode_subframe(x[300 * s : 300 * (s + 1)].tolist(), 0, 0)
        source += src
        ok += good
    return np.array(source, dtype=np.int8), np.array(ok, dtype=bool)


def iode_copies(frame_source: np.ndarray) -> tuple[int, int, int]:
    """The three IODE copies (SF1 IODC 8 LSBs, SF2 IODE, SF3 IODE) of a decoded frame's source bits."""
    src = np.asarray(frame_source)
    if src.shape != (FRAME_BITS,):
        raise ValueError(f"frame_source: the 1500 source bits of one frame (got shape {src.shape})")
    out = []
    for s, first in IODE_COPIES:
        out.append(int("".join(str(int(b)) for b in src[300 * s + first - 1 : 300 * s + first + 7]), 2))
    return out[0], out[1], out[2]


def _vote(rows: np.ndarray) -> np.ndarray:
    """Per-bit majority of 0/1 rows; ties go to the last row."""
    ones = rows.sum(axis=0) * 2
    n = len(rows)
    return np.where(ones > n, 1, np.where(ones < n, 0, rows[-1])).astype(np.int8)


def _reheader(source: np.ndarray, t0: int) -> list[int]:
    """Stored subframe source with preamble, HOW TOW and subframe ID of the subframe starting at ``t0``."""
    src = [int(b) for b in source]
    hdr = lnav.header_bits(t0)
    for lo, hi in ((0, 8), (30, 47), (49, 52)):  # preamble, TOW, subframe ID
        src[lo:hi] = hdr[lo:hi]
    return src


def predict_next_frame(stored_frames_source_bits: np.ndarray, t_next_frame: int, *, content_frames: int = 1) -> np.ndarray:
    """Predicted transmitted bits (1500,) of the frame starting at ``t_next_frame`` (s of week); -1 where none.

    ``stored_frames_source_bits`` (n, 1500): decoded source bits of the n
    consecutive frames before it (last row = the frame at t_next_frame - 30).
    SF1-3: the majority of the last ``content_frames`` rows with the new
    preamble, HOW TOW and subframe ID, re-encoded with the parity chain;
    SF4-5: the majority of rows -25, -50, ... (same page), re-encoded; -1
    when n < 25.  TLM message and HOW flags come from the stored bits.
    """
    rows = np.asarray(stored_frames_source_bits)
    if rows.ndim != 2 or rows.shape[1] != FRAME_BITS or len(rows) < 1 or not np.isin(rows, (0, 1)).all():
        raise ValueError("stored_frames_source_bits: shape (n >= 1, 1500) of 0/1 source bits, last row the latest frame")
    _check_frame_time(t_next_frame, "t_next_frame")
    if not 1 <= content_frames <= len(rows):
        raise ValueError(f"content_frames = {content_frames}: between 1 and the {len(rows)} stored frames")
    content = _vote(rows[-content_frames:])
    page = lnav_pages.page_number(t_next_frame)
    back = [m for m in range(1, len(rows) // PAGE_CYCLE + 1)  # same page: not across the restart at the week start
            if lnav_pages.page_number((t_next_frame - m * PAGE_CYCLE * FRAME_S) % SECONDS_PER_WEEK) == page]
    pages = _vote(rows[[len(rows) - m * PAGE_CYCLE for m in reversed(back)]]) if back else None
    out = np.full(FRAME_BITS, -1, dtype=np.int8)
    tail = (0, 0)
    for s in range(SUBFRAMES):
        t0 = t_next_frame + SUBFRAME_S * s
        store = content if s < 3 else pages
        if store is None:
            tail = (0, 0)  # the previous subframe's word 10 ends in D29 = D30 = 0 (solved bits)
            continue
        sent = lnav.encode_subframe(_reheader(store[300 * s : 300 * (s + 1)], t0), *tail)
        out[300 * s : 300 * (s + 1)] = sent
        tail = (sent[-2], sent[-1])
    return out


# ---- driver for the receiver ------------------------------------------------------------------------------


def _priors_from_bits(bits: np.ndarray, predicted: np.ndarray, eps: float) -> np.ndarray:
    """P(level +1) = P(bit 0): 1 - eps / eps where ``predicted``, 1/2 elsewhere."""
    return np.where(predicted, np.where(bits == 0, 1.0 - eps, eps), 0.5)


class BitPredictor:
    """Per-frame bit priors for the MM filter, with feedback of the filter's decisions.

    ``strategy``: ``"none"``, ``"mask"`` or ``"iode"`` (module docstring).
    ``robust``: the scenario's :class:`RobustPrediction` (needed by "mask"
    and "iode"; frame index k is the frame starting at ``robust.t0 + 30 k``).
    ``history``: decided frames (m, 1500) immediately before frame 0, e.g.
    read in clean conditions before the scenario (25 of them give the IODE
    mode its pages).  ``eps``: prior of the level opposite to a prediction.
    """

    def __init__(
        self,
        strategy: str,
        robust: RobustPrediction | None = None,
        *,
        eps: float = 1e-3,
        history: np.ndarray | Sequence[Sequence[int]] = (),
        open_iode: bool = False,
        n_frames: int | None = None,
    ):
        if strategy not in STRATEGIES:
            raise ValueError(f"strategy = {strategy!r}: one of {', '.join(STRATEGIES)}")
        if strategy != "none" and robust is None:
            raise ValueError(f"strategy {strategy!r} needs robust=robust_prediction(...) of the scenario")
        if not 0.0 < eps < 0.5:
            raise ValueError(f"eps = {eps}: the prior of a contradicted prediction, in (0, 0.5), e.g. 1e-3")
        self.strategy, self.robust, self.eps, self.open_iode = strategy, robust, float(eps), bool(open_iode)
        self.n_frames = robust.n_frames if robust is not None else n_frames
        self._source: list[np.ndarray] = []
        self._iodes: list[tuple[int, int, int]] = []
        self._bits: list[np.ndarray] = []
        hist = np.asarray(history)
        if hist.size and (hist.ndim != 2 or hist.shape[1] != FRAME_BITS):
            raise ValueError(f"history: decided frames of shape (m, 1500), oldest first (got shape {hist.shape})")
        for k, frame in enumerate(hist if hist.size else []):
            self._store(_frame_array(frame, f"history[{k}]"))
        self.n_history = len(self._bits)

    # -- feedback --
    def _store(self, bits: np.ndarray) -> None:
        source, _ = decode_frame(bits)
        self._bits.append(bits)
        self._source.append(source)
        self._iodes.append(iode_copies(source))

    @property
    def n_observed(self) -> int:
        """Frames of the scenario observed so far (the next frame to predict)."""
        return len(self._bits) - self.n_history

    def fork(self) -> BitPredictor:
        """An independent predictor in the same state: observing on either leaves the other unchanged.

        The stored frames are never modified in place and ``robust`` is read
        only, so they are shared; only the lists that :meth:`observe` appends to
        are copied (``copy.deepcopy`` would also copy the whole scenario stream
        of ``robust``).
        """
        new = copy.copy(self)
        new._source, new._iodes, new._bits = list(self._source), list(self._iodes), list(self._bits)
        return new

    def observe(self, frame_bits_decided: Sequence[int] | np.ndarray) -> None:
        """Store the decided transmitted bits (0/1) of the next scenario frame."""
        bits = _frame_array(frame_bits_decided, "frame_bits_decided")
        if self.n_frames is not None and self.n_observed >= self.n_frames:
            raise ValueError(f"observe: all {self.n_frames} frames of the scenario were already observed")
        self._store(bits)

    # -- prediction --
    def _check_index(self, frame_index: int) -> None:
        if self.n_frames is not None and not 0 <= frame_index < self.n_frames:
            raise ValueError(f"frame_index = {frame_index}: the scenario has frames 0..{self.n_frames - 1}")
        if frame_index < 0:
            raise ValueError(f"frame_index = {frame_index}: frames are counted from 0")

    def _t_frame(self, frame_index: int) -> int:
        return (self.robust.t0 + FRAME_S * frame_index) % SECONDS_PER_WEEK

    def iode_locked(self, frame_index: int) -> tuple[bool, int]:
        """(True, run length) when the frame before ``frame_index`` passes the IODE check, else (False, 0).

        Check: its three copies agree, and equal the IODE of the latest earlier
        frame whose copies agreed.  Run length: consecutive frames back from it
        whose three copies all equal that IODE (the frames voted for content).
        """
        last = self.n_history + frame_index - 1
        if last < 1:
            return False, 0
        if last >= len(self._iodes):
            raise ValueError(f"frame_index = {frame_index}: observe frame {frame_index - 1} first ({self.n_observed} observed)")
        now = self._iodes[last]
        if len(set(now)) != 1:
            return False, 0
        stored = next((c[0] for c in reversed(self._iodes[:last]) if len(set(c)) == 1), None)
        if stored != now[0]:
            return False, 0
        run = 0
        while last - run >= 0 and self._iodes[last - run] == now:
            run += 1
        return True, run

    def mode(self, frame_index: int) -> str:
        """Which prediction frame ``frame_index`` gets: "none", "mask" or "iode"."""
        self._check_index(frame_index)
        if self.strategy == "iode" and self.iode_locked(frame_index)[0]:
            return "iode"
        return "none" if self.strategy == "none" else "mask"

    def predicted_bits(self, frame_index: int) -> np.ndarray:
        """Predicted transmitted bits (1500,) of frame ``frame_index``, -1 where no prediction."""
        mode = self.mode(frame_index)
        if mode == "none":
            return np.full(FRAME_BITS, -1, dtype=np.int8)
        bits, mask = self.robust.frame(frame_index)
        fallback = np.where(mask, bits, -1).astype(np.int8)
        if mode == "mask":
            return fallback
        _, run = self.iode_locked(frame_index)
        last = self.n_history + frame_index
        pred = predict_next_frame(np.stack(self._source[:last]), self._t_frame(frame_index), content_frames=run)
        pred = np.where(pred < 0, fallback, pred).astype(np.int8)
        if self.open_iode:
            pred[IODE_POSITIONS] = fallback[IODE_POSITIONS]
        return pred

    def priors(self, frame_index: int) -> np.ndarray:
        """P(transmitted level = +1, i.e. bit 0) for each of the 1500 bits of frame ``frame_index``."""
        pred = self.predicted_bits(frame_index)
        return _priors_from_bits(pred, pred >= 0, self.eps)

    def last_frame(self, frame_index: int) -> np.ndarray:
        """Decided bits of the frame before ``frame_index`` (history or observed)."""
        self._check_index(frame_index)
        last = self.n_history + frame_index - 1
        if not 0 <= last < len(self._bits):
            raise ValueError(f"frame_index = {frame_index}: no decided frame before it (observe it or pass history)")
        return self._bits[last]


def prediction_map(last_frame_bits: Sequence[int] | np.ndarray, next_priors: Sequence[float] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fig. 4 of the paper as arrays: (last 5 subframes, next 5 subframes), each (50 words, 30 bits) of levels.

    Left: the decided bits of the last frame as levels d = 1 - 2 bit (+1/-1).
    Right: +1/-1 where the next frame's prior predicts that level, 0 where
    the prior is 1/2 (grey in the figure).
    """
    last = _frame_array(last_frame_bits, "last_frame_bits")
    p = np.asarray(next_priors, dtype=float)
    if p.shape != (FRAME_BITS,) or not ((p >= 0) & (p <= 1)).all():
        raise ValueError(f"next_priors: 1500 probabilities in [0, 1] (got shape {p.shape})")
    nxt = np.sign(p - 0.5).astype(np.int8)
    return (1 - 2 * last).reshape(50, 30).astype(np.int8), nxt.reshape(50, 30)
