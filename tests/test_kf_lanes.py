"""The lane kernels of the discriminator KFs and the PLL give every trial the bits of the one-trial kernels.

``kf_kernel`` (kf, akf, akf_ar), ``susi_kernel`` (susi_akf, susi_sakf),
``pll_kernel`` and ``mm_kf_loop`` (mm_kf) run ``blocks.LANES`` trials side by side;
``kf_kernel_scalar``, ``susi_kernel_scalar``, ``pll_kernel_scalar`` and
``mm_kf_loop_scalar`` are the former one-trial-at-a-time kernels.  Every
output is compared bit for bit (``uint64`` views: NaN positions, payloads and
signs of zeros included) over batch sizes around the lane count, 10 ms and
1 ms, and a NaN and an inf prompt (the covariance-fail / NaN paths).
"""

from __future__ import annotations

import numpy as np
import pytest

from scintrack.signals.correlator import complex_noise, noise_power, prompts
from scintrack.signals.dynamics import third_order_phase
from scintrack.trackers import blocks
from scintrack.trackers.base import TrackInit, initial_state
from scintrack.trackers.held_series import HeldSeries
from scintrack.trackers.kf import DiscriminatorKF, kf_kernel, kf_kernel_scalar
from scintrack.trackers.mm_kf import COV_ENTRIES, MMKF, mm_kf_loop, mm_kf_loop_scalar
from scintrack.trackers.pll import PLL, pll_kernel, pll_kernel_scalar
from scintrack.trackers.susi_kf import GainWeighting, SusiKF, susi_kernel, susi_kernel_scalar, susi_state

L = blocks.LANES
BATCHES = (1, 5, 31, 32, 33, 100)
N_ALL = 100
NAN_TRIAL, INF_TRIAL = 3, 40
AR = {1: [0.95], 2: [1.6, -0.65], 3: [2.1, -1.5, 0.38]}


def _bits_equal(a, b) -> bool:
    """Every bit equal, except that a NaN equals any NaN.

    Where two NaNs meet in one operation (a NaN phase plus a NaN frequency step, after the
    inf prompt) x86 returns the first operand's, and LLVM may swap the operands of an
    add or multiply, as it did in the PLL's vector code once the discriminator's
    arithmetic (:mod:`scintrack.trackers.trig`) made NaNs of either sign: the sign of
    such a NaN is set by neither IEEE 754 nor LLVM.  Everything else is compared bit for bit.
    """
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    if a.dtype != np.float64:
        return np.array_equal(a, b)
    nan_a, nan_b = np.isnan(a), np.isnan(b)
    return np.array_equal(nan_a, nan_b) and np.array_equal(a[~nan_a].view(np.uint64), b[~nan_b].view(np.uint64))


def _signal(ts: float, k: int, cn0: float = 30.0, seed: int = 0):
    rng = np.random.default_rng(seed)
    thd = third_order_phase(rng.uniform(-np.pi, np.pi, N_ALL), k, ts, 50.0, 100.0)
    y = prompts(thd + np.cumsum(rng.normal(0, 0.03, (N_ALL, k)), axis=1), 1.0, complex_noise(seed, "kf-lanes", range(N_ALL), k, noise_power(cn0, ts)))
    y[NAN_TRIAL, k // 3] = complex(np.nan, np.nan)
    y[INF_TRIAL, k // 2] = complex(np.inf, 0.0)
    init = TrackInit(phase=np.angle(y[:, 0]), doppler_hz=np.full(N_ALL, 50.0), rate_hz_s=np.zeros(N_ALL))
    return np.ascontiguousarray(y), init


def _sub(init: TrackInit, s: slice) -> TrackInit:
    return TrackInit(init.phase[s], init.doppler_hz[s], init.rate_hz_s[s])


def _slices():
    """(batch, slice of the 100 trials): the single trial is the NaN one; the others start at 0 or 7."""
    for n in BATCHES:
        yield n, slice(NAN_TRIAL, NAN_TRIAL + 1) if n == 1 else slice(0 if n in (31, 33, 100) else 7, (0 if n in (31, 33, 100) else 7) + n)


SIGNALS = {ts: _signal(ts, k) for ts, k in ((0.01, 400), (0.001, 700))}


def _kf(kind: str, ts: float) -> DiscriminatorKF:
    kw = dict(ts=ts, q_jerk=0.01, nominal_cn0_hz=1000.0, p0_diag=(0.25, 1.0, 1e4))
    if kind == "kf":
        return DiscriminatorKF(**kw)
    if kind == "kf_neg_p0":  # a non-PSD P0: the covariance test fails from epoch 0
        return DiscriminatorKF(**{**kw, "p0_diag": (0.25, -1.0, 1e4)})
    if kind == "akf":
        return DiscriminatorKF(**kw, adaptive_r=True)
    p = int(kind[-1])  # akf_ar1 .. akf_ar3
    return DiscriminatorKF(**kw, adaptive_r=True, ar_coefs=np.array(AR[p]), ar_sigma2=1e-3)


@pytest.mark.parametrize("ts", sorted(SIGNALS))
@pytest.mark.parametrize("kind", ["kf", "kf_neg_p0", "akf", "akf_ar1", "akf_ar2", "akf_ar3"])
def test_kf_lane_kernel_is_the_scalar_kernel_bit_for_bit(kind, ts):
    y, init = SIGNALS[ts]
    tr = _kf(kind, ts)
    scalar = kf_kernel_scalar(y, tr.params(init))  # (theta_d, R, total_phase, cov_fail_epoch) of every trial
    assert np.isnan(scalar[0][NAN_TRIAL, -1])  # the NaN path is exercised
    if tr.adaptive_r:
        assert scalar[3][NAN_TRIAL] >= 0  # NaN R -> NaN P -> the covariance test fails
    if kind == "kf_neg_p0":
        assert (scalar[3] == 0).all()
    for n, s in _slices():
        lanes = kf_kernel(y[s], tr.params(_sub(init, s)))
        for j, (a, b) in enumerate(zip(lanes, scalar)):
            b = b[s] if b.size else b
            assert _bits_equal(a, b), (kind, ts, n, j)
    # and through the tracker interface: the same extras
    out = tr.run(y[:33], _sub(init, slice(0, 33)))
    assert _bits_equal(out.theta_d, scalar[0][:33])
    assert _bits_equal(out.extras["cov_fail_epoch"], scalar[3][:33])
    if tr.ar_coefs is not None:
        assert _bits_equal(out.extras["total_phase"], scalar[2][:33])


# --- Susi et al.: AKF / SAKF PLL ---------------------------------------------------


def _susi_run_scalar(tr: SusiKF, y: np.ndarray, init: TrackInit):
    """``SusiKF.run`` as it was, on the one-trial kernel with the state in per-trial arrays."""
    n_tr, k = y.shape
    prm = tr.params()
    x = initial_state(init, 3)
    P = np.broadcast_to(prm.P0, (n_tr, 3, 3)).copy()
    w = prm.window
    buf2, buf4 = np.zeros((n_tr, w)), np.zeros((n_tr, w))
    sums = np.zeros((n_tr, 2))
    counters = np.zeros((n_tr, 2), dtype=np.int64)
    out, innov, freq, r_out = (np.empty((n_tr, k)) for _ in range(4))
    cov_fail = np.full(n_tr, -1, dtype=np.int64)
    series = {"discriminator": innov, "frequency_hz": freq, "R": r_out}
    scint_names = ("phi3", "T", "p", "weight")
    if tr.scintillation:
        series.update({name: np.full((n_tr, k), np.nan) for name in scint_names})
    sc = tr._initial_scint(n_tr)
    for i0, i1 in tr._schedule(k):
        susi_kernel_scalar(y, i0, i1, prm, x, P, buf2, buf4, sums, counters, sc["s_phi"], sc["s_f"], sc["weight"], out, innov, freq, r_out, cov_fail)
        if tr.scintillation:
            for name in scint_names:
                series[name][:, i0:i1] = sc[name][:, None]
            if i1 >= tr.n_window:
                sc = tr.scintillation_update(out[:, i1 - tr.n_window : i1])
    return tr._outputs(out, series, cov_fail)


def _susi(kind: str, ts: float) -> SusiKF:
    kw = dict(ts=ts, clock="ocxo", q_jerk=0.01, nominal_cn0_hz=1000.0, p0_diag=(0.25, 1.0, 1e4),
              record=("discriminator", "frequency_hz", "R", "phi3", "T", "p", "weight"))
    scint = dict(scintillation=True, window_s=1.0, fit_band_hz=(0.5, 5.0)) if ts == 0.01 else dict(scintillation=True, window_s=0.3, fit_band_hz=(4.0, 40.0))
    return {
        "akf_atan": lambda: SusiKF(**kw, discriminator="atan"),
        "akf_atan2": lambda: SusiKF(**kw, discriminator="atan2"),
        "akf_nominal_r": lambda: SusiKF(**kw, discriminator="atan", adaptive_r=False),
        "sakf_atan2": lambda: SusiKF(**kw, discriminator="atan2", **scint),
        "sakf_atan_hop7_weighted": lambda: SusiKF(**kw, discriminator="atan", **scint, update_s=7 * ts, weighting=GainWeighting(0.7, 0.3, 2.0)),
    }[kind]()


@pytest.mark.parametrize("ts", sorted(SIGNALS))
@pytest.mark.parametrize("kind", ["akf_atan", "akf_atan2", "akf_nominal_r", "sakf_atan2", "sakf_atan_hop7_weighted"])
def test_susi_lane_kernel_is_the_scalar_kernel_bit_for_bit(kind, ts):
    """Through ``SusiKF.run`` (chunks between the scintillation refreshes), against the same driver on the
    one-trial kernel on the same batch (the refresh is row by row, so each batch compared with itself
    tests the kernels; batch independence of the whole run: ``tests/test_shard_batches.py``)."""
    y, init = SIGNALS[ts]
    tr = _susi(kind, ts)
    for n, s in _slices():
        scalar = _susi_run_scalar(tr, y[s], _sub(init, s))
        if s.start <= NAN_TRIAL < s.stop:
            assert np.isnan(scalar.theta_d[NAN_TRIAL - s.start, -1])  # the NaN path is exercised
        if tr.scintillation and n > 1:
            assert np.isfinite(scalar.extras["p"][:, -1]).any()  # the scintillation refresh ran
        lanes = tr.run(y[s], _sub(init, s))
        if tr.scintillation:  # the monitors held per chunk of the schedule (compared as arrays below)
            assert all(isinstance(lanes.extras[m], HeldSeries) for m in ("phi3", "T", "p", "weight"))
            assert list(lanes.extras["T"].starts) == [i0 for i0, _ in tr._schedule(y.shape[1])]
        assert _bits_equal(lanes.theta_d, scalar.theta_d), (kind, ts, n)
        assert lanes.extras.keys() == scalar.extras.keys()
        for key in scalar.extras:
            assert _bits_equal(lanes.extras[key], scalar.extras[key]), (kind, ts, n, key)


@pytest.mark.parametrize("costas", [True, False])
def test_susi_kernel_over_irregular_chunks_with_changing_psds_and_weights(costas):
    """Direct kernel calls over an irregular chunk schedule (single epochs, a chunk across the M2M4 lap,
    the rest), with new per-trial s_phi, s_f and weights for every chunk."""
    ts = 0.01
    y, init = SIGNALS[ts]
    y = y[:37]
    n_tr, k = y.shape
    tr = SusiKF(ts=ts, clock="rubidium", q_jerk=0.02, nominal_cn0_hz=800.0, p0_diag=(0.25, 1.0, 1e4), discriminator="atan" if costas else "atan2")
    prm = tr.params()
    rng = np.random.default_rng(5)
    x0 = initial_state(_sub(init, slice(0, n_tr)), 3)
    # scalar state
    x, P = x0.copy(), np.broadcast_to(prm.P0, (n_tr, 3, 3)).copy()
    buf2, buf4 = np.zeros((n_tr, prm.window)), np.zeros((n_tr, prm.window))
    sums, counters = np.zeros((n_tr, 2)), np.zeros((n_tr, 2), dtype=np.int64)
    st = susi_state(x0, prm.P0, prm.window)
    outs = [[np.empty((n_tr, k)) for _ in range(4)] + [np.full(n_tr, -1, dtype=np.int64)] for _ in range(2)]
    bounds = [0, 1, 2, 3, 17, 49, 50, 51, 130, 131, 250, k]
    for i0, i1 in zip(bounds[:-1], bounds[1:]):
        s_phi, s_f = rng.exponential(1e-3, n_tr), rng.exponential(1e-4, n_tr)
        weight = rng.uniform(0.3, 1.2, n_tr)
        susi_kernel_scalar(y, i0, i1, prm, x, P, buf2, buf4, sums, counters, s_phi, s_f, weight, *outs[0])
        susi_kernel(y, i0, i1, prm, st, s_phi, s_f, weight, *outs[1])
        # the carried state is the scalar one, lane by lane
        lane_x = st.x.transpose(0, 2, 1).reshape(-1, 3)[:n_tr]
        assert _bits_equal(np.ascontiguousarray(lane_x), x)
        assert _bits_equal(np.ascontiguousarray(st.P.transpose(0, 3, 1, 2).reshape(-1, 3, 3)[:n_tr]), P)
        assert (st.counters == counters[0]).all() and (counters == counters[0]).all()
    for a, b in zip(*outs):
        assert _bits_equal(a, b)


@pytest.mark.parametrize("ts", sorted(SIGNALS))
@pytest.mark.parametrize("discriminator", ["atan2", "atan"])
def test_pll_lane_kernel_is_the_scalar_kernel_bit_for_bit(discriminator, ts):
    y, init = SIGNALS[ts]
    tr = PLL(ts=ts, bandwidth_hz=10.0, discriminator=discriminator)
    scalar = pll_kernel_scalar(y, tr.params(init))  # (phase, frequency, discriminator)
    assert np.isnan(scalar[0][NAN_TRIAL, -1])
    for n, s in _slices():
        lanes = pll_kernel(y[s], tr.params(_sub(init, s)))
        for j, (a, b) in enumerate(zip(lanes, scalar)):
            assert _bits_equal(a, b[s]), (discriminator, ts, n, j)


def _mm_loop(loop, tr, y, init, start=None, previous=None):
    """(theta, freq, amp, p_plus, log_odds, cn0, covariance, cov_fail) of ``loop`` from ``start`` (default 0),
    on copies of ``previous``' arrays (a resume) or new ones."""
    n, k = y.shape
    arrays = [np.empty((n, k)) for _ in range(6)] + [np.empty((n, k, len(COV_ENTRIES))), np.full(n, -1, dtype=np.int64)]
    if previous is not None:
        arrays = [a.copy() for a in previous]
    loop(y, tr.params(y, init), np.zeros(n, dtype=np.int64) if start is None else start, *arrays)
    return arrays


@pytest.mark.parametrize("r", ["m2m4", 0.3])
@pytest.mark.parametrize("priors", ["pilot", "unknown", "mixed"])
def test_mm_lane_loop_is_the_scalar_loop_bit_for_bit_from_epoch_0_and_resumed(priors, r):
    """The MM filter's lanes against its one-trial loop: every output and the kept covariance, over the
    batch sizes, with pilot, unknown (1/2) and mixed priors (0, 1, 1/2, 0.9: known bits of either sign
    give the log-sum-exp's -inf branches), sliding-M2M4 and fixed R, from epoch 0 and resumed from a
    different epoch per trial (0, inside the M2M4 start-up window, later, past the end)."""
    y, init = SIGNALS[0.01]
    rng = np.random.default_rng(11)
    bits = {"pilot": None, "unknown": np.full(y.shape, 0.5), "mixed": rng.choice([0.0, 1.0, 0.5, 0.9], y.shape)}[priors]
    full = TrackInit(init.phase, init.doppler_hz, init.rate_hz_s, bit_prior=bits)
    tr = MMKF(ts=0.02, r=r, m2m4_window=40)
    scalar = _mm_loop(mm_kf_loop_scalar, tr, y, full)
    assert np.isnan(scalar[0][NAN_TRIAL, -1])
    start = rng.choice([0, 1, 25, 200, y.shape[1] - 1, y.shape[1] + 5], N_ALL).astype(np.int64)
    resumed = _mm_loop(mm_kf_loop_scalar, tr, y, full, start, scalar)
    for n, s in _slices():
        sub = TrackInit(init.phase[s], init.doppler_hz[s], init.rate_hz_s[s], bit_prior=None if bits is None else bits[s])
        lanes = _mm_loop(mm_kf_loop, tr, y[s], sub)
        for j, (a, b) in enumerate(zip(lanes, scalar)):
            assert _bits_equal(a, b[s]), (priors, r, n, j)
        again = _mm_loop(mm_kf_loop, tr, y[s], sub, start[s], [a[s] for a in scalar])
        for j, (a, b) in enumerate(zip(again, resumed)):
            assert _bits_equal(a, b[s]), ("resumed", priors, r, n, j)


def test_lane_update_raises_on_a_zero_innovation_variance_as_the_scalar_one_does():
    H = np.array([1.0, 0.0, 0.0])
    with pytest.raises(ZeroDivisionError):
        blocks.scalar_update(np.zeros(3), np.zeros((3, 3)), np.empty(3), H, 0.0, 0.1)
    x, P, PH = blocks.lanes_empty((3, L)), blocks.lanes_empty((3, 3, L)), blocks.lanes_empty((3, L))
    x[:], P[:] = 0.0, 0.0
    P[0, 0, :] = 1.0
    P[0, 0, 7] = 0.0  # one lane with S = 0
    R, nu, w = np.zeros(L), np.full(L, 0.1), np.ones(L)
    with pytest.raises(ZeroDivisionError):
        blocks.scalar_update_lanes(x, P, PH, H, R, nu)
    with pytest.raises(ZeroDivisionError):
        blocks.weighted_scalar_update_lanes(x, P, PH, H, R, nu, w)
    P[0, 0, 7] = 1.0
    blocks.scalar_update_lanes(x, P, PH, H, R, nu)  # no zero lane: no error
    assert np.allclose(x[0], 0.1)
