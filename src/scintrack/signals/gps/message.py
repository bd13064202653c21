"""The transmitted LNAV bit stream of one satellite over a time span, with data-set scheduling.

IS-GPS-200 Rev D, Sec. 20.3 (notes ``gps-lnav-mm.md`` Sec. 1.1 and 1.4):

* the stream is whole frames of 1500 bits (50 bit/s); it starts at the frame
  boundary at/before the requested start and ends at the one at/after the
  requested end; subframes 1-3 come from the data set in force
  (:mod:`lnav`), 4-5 from the pages (:mod:`lnav_pages`), HOW TOW and subframe
  ID from time, and parity is chained across the whole stream (D29*/D30*
  carried from word to word and subframe to subframe);
* SF1 WN is the week of transmission (RINEX gives the week of t_oc, which
  differs for sets sent before a week change);
* data sets change only at frame boundaries (Sec. 20.3.4.1).

Scheduling (:class:`Schedule`), with the choices the spec leaves open:

* **Regular sets** (:func:`regular_datasets`).  The set whose t_oe is on an
  even hour T is in force during [T - 2 h, T) (normal operations: 2-h
  transmission, 4-h fit, Sec. 20.3.4.4); the cutover at an even hour is a
  frame boundary (7200 = 240 x 30 s).  Several with the same t_oe: the
  earliest-received one.  If the file lacks the set with t_oe = T, the file's
  set with the latest t_oe in (T - 2 h, T) is sent in that slot (in the real
  file these are the hh:59:44 sets the control segment uploaded instead, e.g.
  PRN 11 at 11:59:44); without one either, the previous slot's set stays in
  force (still inside its 4-h fit interval, as a satellite without fresh data
  keeps sending what it has); otherwise ValueError.
* **Uploads** (:class:`Upload` (prn, time_s)).  Cut in at the first frame
  boundary t_c >= time_s and in force until the next even hour T (the end of
  the current 2-h slot); from T on, the regular sets continue (the real CS
  keeps an uploaded sequence with t_oe = hh:59:44 for later slots too; going
  back to the file's sets keeps every later frame identical to the
  upload-free stream).  The set is the regular set in force at t_c (the one
  with t_oe at the next even hour T, i.e. the regular set the upload replaces)
  re-referenced to t_oe' = T - 16 s (one t_oe LSB; real uploads have
  t_oe = hh:59:44), or T - 32 s, ... if the set in force already has that
  t_oe (Sec. 20.3.3.4.1: the first set of an upload has a t_oe different
  from the previous one).  Several uploads of a PRN apply in time order; the
  latest cut-in wins.
* **Upload IODC/IODE** (Sec. 20.3.4.4: IODE not reused within 6 h, IODC not
  within 7 days).  IODE candidates exclude the IODE of every file set of that
  PRN with t_oe in [t_c - 6 h, t_c + 8 h] (any set sent within 6 h of t_c,
  before or after, since a set is sent at most 2 h before its t_oe) and of
  earlier uploads in that window; IODC candidates exclude every IODC of that
  PRN within 7 days.  Pick: the smallest 8-bit IODE, with the IODC's two
  MSBs of the set in force (then the other MSBs in order 0..3); IODE = IODC
  mod 256.  Small values are out of sequence with respect to the regular
  sequence by construction, as in the real example (PRN 1: IODE 72 -> 1).

Re-referencing a data set to a new t_oe' (:func:`rereference`), with
dt = t_oe' - t_oe and the user algorithm of Table 20-IV:

* M_k = M0 + n (t - t_oe) with n = sqrt(mu/A^3) + delta_n unchanged, so
  M0' = M0 + n dt gives the same M_k at every t, hence the same E_k, nu_k,
  Phi_k and the same harmonic corrections (C_us..., e, sqrt(A), omega kept);
* Omega_k = Omega0 + (OMEGADOT - OMEGAE_DOT)(t - t_oe) - OMEGAE_DOT t_oe
  = Omega0 + OMEGADOT (t - t_oe) - OMEGAE_DOT t, so Omega0' = Omega0 + OMEGADOT dt;
* i_k = i0 + IDOT (t - t_oe) + delta_i_k, so i0' = i0 + IDOT dt;
* clock: t_oc' = t_oe'; with d = t_oc' - t_oc the polynomial
  a_f0 + a_f1 (t - t_oc) + a_f2 (t - t_oc)^2 is unchanged when
  a_f0' = a_f0 + a_f1 d + a_f2 d^2, a_f1' = a_f1 + 2 a_f2 d, a_f2' = a_f2.

The relations are exact; the only differences come from rounding M0',
Omega0', i0' to 2^-31 sc (<= 2 cm each at GPS radius), a_f0' to 2^-31 s and,
when a_f2 != 0, a_f1' to 2^-43.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from . import lnav, lnav_pages
from .ephemeris import SECONDS_PER_WEEK, DataSetFields, Ephemeris, NavHeader
from .lnav import LNAVDecodeError
from .orbit import week_crossover

FRAME_S = 30
SUBFRAME_S = 6
BIT_RATE = 50
SLOT_S = 7200
UPLOAD_TOE_STEP = 16
IODE_REUSE_S = 6 * 3600
IODC_REUSE_S = 7 * 86400


@dataclass(frozen=True)
class Upload:
    """A navigation upload of satellite ``prn`` at ``time_s`` (seconds of the message's week)."""

    prn: int
    time_s: float

    def __post_init__(self) -> None:
        if not 1 <= int(self.prn) <= 32:
            raise ValueError(f"Upload.prn = {self.prn}: a GPS PRN 1..32")
        if not (math.isfinite(self.time_s) and 0 <= self.time_s < SECONDS_PER_WEEK):
            raise ValueError(f"Upload.time_s = {self.time_s}: seconds of week in [0, 604800)")


@dataclass(frozen=True)
class DataSet(DataSetFields):
    """A data set as scheduled: ``fields`` in LNAV units, in force during [t_on, t_off) (GPS seconds since the epoch)."""

    kind: str  # "regular" or "upload"
    fields: Mapping[str, float]
    t_on: int
    t_off: int
    t_oe_abs: int


def _toe_abs(eph: Ephemeris) -> int:
    return int(round(lnav_pages.reference_times(eph)[0]))


def rereference(fields: Mapping[str, float], dt: float) -> dict[str, float]:
    """The same orbit and clock with t_oe' = t_oe + dt and t_oc' = t_oe' (relations in the module docstring)."""
    f = dict(fields)
    t_oe_new = (float(fields["t_oe"]) + dt) % SECONDS_PER_WEEK
    d_clk = float(week_crossover(t_oe_new - float(fields["t_oc"])))
    a_f0, a_f1, a_f2 = (float(fields[k]) for k in ("a_f0", "a_f1", "a_f2"))
    f.update(
        t_oe=t_oe_new,
        t_oc=t_oe_new,
        m0=lnav_pages.wrap_semicircles(float(fields["m0"]) + lnav_pages.corrected_mean_motion(fields) * dt),
        omega0=lnav_pages.wrap_semicircles(float(fields["omega0"]) + float(fields["omega_dot"]) * dt),
        i0=float(fields["i0"]) + float(fields["idot"]) * dt,
        a_f0=a_f0 + a_f1 * d_clk + a_f2 * d_clk**2,
        a_f1=a_f1 + 2.0 * a_f2 * d_clk,
    )
    return f


def regular_datasets(ephemerides: Sequence[Ephemeris], prn: int) -> dict[int, Ephemeris]:
    """Data set of ``prn`` transmitted in each 2-h slot, keyed by the slot's end T (GPS seconds since the epoch).

    The set with t_oe = T; without one, the file's set with the latest t_oe in
    (T - 2 h, T) (e.g. an hh:59:44 set the control segment uploaded for that
    slot).  Several candidates with the same t_oe: the earliest received.
    """
    out: dict[int, tuple[int, Ephemeris]] = {}
    for eph in sorted((e for e in ephemerides if e.prn == prn), key=lambda e: e.transmit_time):
        t = _toe_abs(eph)
        slot_end = SLOT_S * math.ceil(t / SLOT_S)
        best = out.get(slot_end)
        if best is None or (t > best[0] if t % SLOT_S else best[0] % SLOT_S != 0):
            out[slot_end] = (t, eph)
    return {slot_end: eph for slot_end, (_, eph) in out.items()}


class Schedule:
    """Which data set a satellite transmits at each frame: regular even-hour sets plus uploads (module docstring)."""

    def __init__(self, ephemerides: Sequence[Ephemeris], prn: int, week: int, uploads: Sequence[Upload] = ()):
        self.prn, self.week = int(prn), int(week)
        self._all = [e for e in ephemerides if e.prn == self.prn]
        if not self._all:
            raise ValueError(f"ephemerides: no data set for PRN {prn}; choose a PRN present in the navigation file")
        self._regular = regular_datasets(self._all, self.prn)
        self.uploads: list[DataSet] = []
        events = sorted({u for u in uploads if u.prn == self.prn}, key=lambda u: u.time_s)
        for up in events:
            self.uploads.append(self._make_upload(self.week * SECONDS_PER_WEEK + FRAME_S * math.ceil(up.time_s / FRAME_S)))

    def regular_at(self, t: int) -> DataSet:
        """The regular set in force at absolute time ``t``."""
        slot_end = SLOT_S * (t // SLOT_S + 1)
        for end in (slot_end, slot_end - SLOT_S):
            if end in self._regular:
                eph = self._regular[end]
                return DataSet("regular", dict(eph.fields), slot_end - SLOT_S, slot_end, _toe_abs(eph))
        raise ValueError(
            f"ephemerides: PRN {self.prn} has no data set with t_oe in ({slot_end - 2 * SLOT_S}, {slot_end}] GPS s "
            f"(week {slot_end // SECONDS_PER_WEEK}); use a navigation file covering the requested span"
        )

    def at(self, t: int) -> DataSet:
        """The data set in force at absolute time ``t`` (GPS seconds since the epoch)."""
        for ds in reversed(self.uploads):
            if ds.t_on <= t < ds.t_off:
                return ds
        return self.regular_at(t)

    def _make_upload(self, t_c: int) -> DataSet:
        current = self.at(t_c)
        base = self.regular_at(t_c)
        slot_end = SLOT_S * (t_c // SLOT_S + 1)
        t_oe_new = slot_end - UPLOAD_TOE_STEP
        while t_oe_new == current.t_oe_abs:
            t_oe_new -= UPLOAD_TOE_STEP
        fields = rereference(base.fields, t_oe_new - base.t_oe_abs)
        iodc = self._pick_iodc(t_c, current.iodc >> 8)
        fields.update(iodc=iodc, iode=iodc % 256)
        return DataSet("upload", fields, t_c, slot_end, t_oe_new)

    def _pick_iodc(self, t_c: int, msb: int) -> int:
        known = [(_toe_abs(e), e.iode, e.iodc) for e in self._all] + [(u.t_oe_abs, u.iode, u.iodc) for u in self.uploads]
        used_iode = {iode for t, iode, _ in known if t_c - IODE_REUSE_S <= t <= t_c + IODE_REUSE_S + SLOT_S}
        used_iodc = {iodc for t, _, iodc in known if abs(t - t_c) <= IODC_REUSE_S}
        for hi in (msb, *[m for m in range(4) if m != msb]):
            for lo in range(256):
                if lo not in used_iode and (hi << 8 | lo) not in used_iodc:
                    return hi << 8 | lo
        raise ValueError(f"PRN {self.prn}: no free IODC/IODE for an upload at GPS second {t_c}")


@dataclass(frozen=True)
class Message:
    """The LNAV stream of one PRN.

    ``bits`` are the transmitted 0/1 bits from ``t0`` (seconds of ``week``) at
    50 bit/s; ``source`` is what a receiver holds after undoing the D30*
    inversion (data bits d1..d24 including the solved bits, and the parity
    bits as sent), so ``bits == source`` except data bits of words whose
    previous word ended in 1.  Per-subframe arrays: start time, subframe
    ID, page and SV ID (subframes 4-5, else -1), the IODE copy the subframe
    carries (SF1: IODC 8 LSBs, SF2/SF3: IODE, else -1), and the IODC, t_oe
    and kind of the data set in force during the subframe's frame.
    """

    prn: int
    week: int
    t0: int
    bits: np.ndarray
    source: np.ndarray
    subframe_t0: np.ndarray
    subframe_id: np.ndarray
    page: np.ndarray
    sv_id: np.ndarray
    iode: np.ndarray
    iodc: np.ndarray
    t_oe: np.ndarray
    dataset_kind: np.ndarray

    @property
    def t_end(self) -> int:
        return self.t0 + len(self.bits) // BIT_RATE


def source_from_transmitted(bits: np.ndarray, d30_before: int = 0) -> np.ndarray:
    """Undo the D30* inversion of a word-aligned stream (``d30_before``: last bit before the first word)."""
    words = np.asarray(bits, dtype=np.int8).reshape(-1, lnav.WORD_BITS)
    prev = np.concatenate(([d30_before], words[:-1, -1])).astype(np.int8)
    out = words.copy()
    out[:, :24] ^= prev[:, None]
    return out.reshape(-1)


def build_message(
    ephemerides: Sequence[Ephemeris],
    header: NavHeader,
    prn: int,
    week: int,
    t_start: float,
    t_end: float,
    uploads: Sequence[Upload] = (),
    *,
    pages: lnav_pages.PageData | None = None,
) -> Message:
    """The transmitted LNAV stream of ``prn`` covering [t_start, t_end] (seconds of ``week``), whole frames.

    ``pages`` defaults to :func:`lnav_pages.build_page_data` of the same
    ephemerides and header (shared by every PRN, as the real almanac is);
    ``uploads`` of other PRNs are ignored.  The span must lie in one week.
    """
    if not (0 <= t_start < t_end <= SECONDS_PER_WEEK):
        raise ValueError(f"t_start = {t_start}, t_end = {t_end}: need 0 <= t_start < t_end <= 604800 (one week)")
    schedule = Schedule(ephemerides, prn, week, uploads)
    pages = lnav_pages.build_page_data(ephemerides, header) if pages is None else pages
    f0, f1 = FRAME_S * math.floor(t_start / FRAME_S), FRAME_S * math.ceil(t_end / FRAME_S)
    sent: list[int] = []
    rows = []
    tail = (0, 0)
    for tf in range(f0, f1, FRAME_S):
        ds = schedule.at(week * SECONDS_PER_WEEK + tf)
        fields = {**ds.fields, "wn": week % 1024}
        page = lnav_pages.page_number(tf)
        for k in range(5):
            t0 = tf + SUBFRAME_S * k
            if k < 3:
                src = lnav.source_bits(t0, fields)
                iode_copy, pg, sv = (ds.iodc % 256 if k == 0 else ds.iode), -1, -1
            else:
                src = lnav_pages.page_source_bits(t0, pages)
                iode_copy, pg = -1, page
                sv = lnav._get(src, 63, 6)
            out = lnav.encode_subframe(src, *tail)
            tail = (out[-2], out[-1])
            sent += out
            rows.append((t0, k + 1, pg, sv, iode_copy, ds.iodc, ds.t_oe, ds.kind))
    bits = np.array(sent, dtype=np.int8)
    cols = list(zip(*rows))
    return Message(
        prn=int(prn), week=int(week), t0=f0, bits=bits, source=source_from_transmitted(bits),
        subframe_t0=np.array(cols[0], dtype=np.int64), subframe_id=np.array(cols[1], dtype=np.int8),
        page=np.array(cols[2], dtype=np.int8), sv_id=np.array(cols[3], dtype=np.int8),
        iode=np.array(cols[4], dtype=np.int16), iodc=np.array(cols[5], dtype=np.int16),
        t_oe=np.array(cols[6], dtype=np.int64), dataset_kind=np.array(cols[7]),
    )


@dataclass(frozen=True)
class DecodedSubframe:
    """One subframe found in a bit stream: where, when, parity verdicts per word, and its fields."""

    offset: int
    t0: int
    subframe_id: int
    inverted: bool
    parity_ok: tuple[bool, ...]
    fields: Mapping[str, object]

    @property
    def ok(self) -> bool:
        return all(self.parity_ok)


_PREAMBLE_BITS = np.array([(lnav.PREAMBLE >> (7 - k)) & 1 for k in range(8)], dtype=np.int8)


def _sync(x: np.ndarray) -> tuple[int, int] | None:
    """(polarity, offset mod 300) with the most preambles whose TLM and HOW pass parity."""
    best, best_score = None, 0
    n = len(x)
    for inv in (0, 1):
        y = x ^ inv
        if n < 60:
            break
        windows = np.lib.stride_tricks.sliding_window_view(y[: n - 52], 8)
        hits = np.flatnonzero((windows == _PREAMBLE_BITS).all(axis=1))
        scores: dict[int, int] = {}
        for k in hits:
            d29, d30 = (int(y[k - 2]), int(y[k - 1])) if k >= 2 else (0, 0)
            tlm = lnav._get(y, k + 1, 30)
            how = lnav._get(y, k + 31, 30)
            if lnav.decode_word(tlm, d29, d30)[1] and lnav.decode_word(how, (tlm >> 1) & 1, tlm & 1)[1]:
                scores[int(k) % 300] = scores.get(int(k) % 300, 0) + 1
        for off, score in sorted(scores.items()):
            if score > best_score:
                best, best_score = (inv, off), score
    return best


def _bit_array(bits: Sequence[int]) -> np.ndarray:
    """``bits`` as an int8 array, or :class:`lnav.LNAVDecodeError` if it is not a 1-D stream of 0/1 values."""
    try:
        x = np.asarray(bits)
    except (ValueError, TypeError) as exc:  # ragged or unconvertible
        raise LNAVDecodeError(f"bits: not an array of bits ({type(exc).__name__}); pass a 1-D sequence of 0/1 values") from None
    if x.ndim != 1 or (x.size and x.dtype.kind not in "biuf"):
        raise LNAVDecodeError(f"bits: expected a 1-D sequence of 0/1 values, got shape {x.shape} of {x.dtype}; pass the hard-decided data bits")
    bad = np.flatnonzero((x != 0) & (x != 1))
    if bad.size:
        raise LNAVDecodeError(f"bits: value {x[bad[0]]!r} at index {int(bad[0])} is not 0 or 1; pass hard-decided 0/1 data bits (not +-1 or soft values)")
    return x.astype(np.int8)


def decode_message(bits: Sequence[int]) -> list[DecodedSubframe]:
    """Find the subframes of a received 0/1 bit stream (any start, either polarity) and decode them.

    Synchronisation: the bit offset (mod 300) and polarity at which most
    preambles are followed by a TLM and HOW that pass parity; then every whole
    subframe from there is decoded with the parity chain carried from the
    bits before it.  Fields: :func:`lnav.read_fields` for subframes 1-3,
    :func:`lnav_pages.read_page` for 4-5 (page from the HOW time).  Random
    bits give subframes with failed parity (or none), not an error;
    anything but a 1-D stream of 0/1 raises :class:`LNAVDecodeError`.
    """
    x = _bit_array(bits)
    found = _sync(x)
    if found is None:
        return []
    inv, off = found
    y = x ^ inv
    out = []
    for k in range(off, len(y) - lnav.SUBFRAME_BITS + 1, lnav.SUBFRAME_BITS):
        d29, d30 = (int(y[k - 2]), int(y[k - 1])) if k >= 2 else (0, 0)
        src, ok = lnav.decode_subframe(y[k : k + lnav.SUBFRAME_BITS].tolist(), d29, d30)
        tow17 = lnav._get(src, 31, 17)
        sf = lnav._get(src, 50, 3)
        t0 = (tow17 * 6 - 6) % SECONDS_PER_WEEK
        if sf in (4, 5):
            fields: dict[str, object] = lnav_pages.read_page(src, page=lnav_pages.page_number(t0))
        else:
            fields = lnav.read_fields(src)
        out.append(DecodedSubframe(offset=k, t0=t0, subframe_id=sf, inverted=bool(inv), parity_ok=tuple(ok), fields=fields))
    return out
