"""The lane kernels against the one oracle of each filter, its numpy ``reference()``.

Every tracker runs its filter in a numba kernel that processes ``LANES`` (32)
trials side by side, one SIMD vector per state entry (``pll_kernel``,
``kf_kernel``, ``susi_kernel``, ``aekf_kernel``, ``mm_kf_loop``).  For every
tracker type (pll, kf, akf, akf_ar, aekf_ar and its options, susi_akf,
susi_sakf, mm_kf), at 10 ms and 1 ms:

* the kernel agrees with the tracker's textbook ``reference()`` (explicit
  matrices, ``numpy.linalg``) within :data:`RTOL` / :data:`ATOL`;
* a trial's result does not depend on its batch: every output is the same,
  bit for bit, in a batch of 1, 31, 32 or 33 trials (inside one lane block, a
  short block, a full block, a full block and one more) as in a batch of 40;
* a NaN prompt, an inf prompt and a stretch of zero prompts (signal and noise
  gone) take their documented paths (NaN from that epoch on, the covariance
  test failing where R becomes NaN, a non-PSD P0 failing at epoch 0, a zero
  innovation variance or a whole M2M4 window of zero prompts raising
  ZeroDivisionError) and stay in their trial.
"""

from __future__ import annotations

import numpy as np
import pytest

from scintrack.models.ar import ScintillationAR
from scintrack.signals.correlator import complex_noise, noise_power, prompts
from scintrack.signals.dynamics import third_order_phase
from scintrack.trackers import blocks
from scintrack.trackers.aekf_ar import AEKFAR
from scintrack.trackers.base import TrackInit, initial_state
from scintrack.trackers.held_series import HeldSeries
from scintrack.trackers.kf import AKF, AKFAR, KF
from scintrack.trackers.mm_kf import COV_ENTRIES, MMKF, mm_kf_loop, two_mode_iq_update_lanes
from scintrack.trackers.pll import PLL
from scintrack.trackers.susi_kf import GainWeighting, SusiAKF, SusiSAKF, susi_kernel, susi_state

L = blocks.LANES
N = 40  # trials of the whole batch: a full lane block and a short one
K = 400  # epochs
NAN_TRIAL, INF_TRIAL, ZERO_TRIAL = 3, 20, 9
NAN_EPOCH, INF_EPOCH, ZERO_EPOCHS = K // 3, K // 2, slice(250, 270)  # zeros: shorter than every M2M4 window
#: (batch size, its trials): the trial with the NaN prompt alone, and batches that put the trials in other lanes
BATCHES = {1: [NAN_TRIAL], 31: list(range(2, 33)), 32: list(range(7, 39)), 33: list(range(0, 33))}

#: Kernel against reference: ``|a - b| <= ATOL + RTOL |b|`` for every output, NaN where the other is NaN.
#: The two differ by rounding only (closed-form gains and sparse F against numpy.linalg.inv and full matrix
#: products).  Measured over every tracker below, 400 epochs at 10 ms and 1 ms, signals of seeds 0-3: the
#: largest difference is 5.7e-10 (1 + |b|), the SAKF's power-law exponent p (fitted to the tracker's own
#: phases, so their rounding differences pass through a least-squares fit), then 1.8e-10 (1 + |b|) (its T);
#: theta_d 9.4e-11 (1 + |b|) (the non-PSD P0, whose covariance is wrong from the start), 3.9e-14 for the MM
#: filter.  RTOL = ATOL = 1e-8 leaves a margin of about 20 over the largest, while a model off by 10 % in
#: one parameter (q_jerk, the AR sigma^2, the AEKF's noise prior; 1 % of the PLL bandwidth) already differs by
#: 4e-6 (1 + |b|) or more.
RTOL = ATOL = 1e-8
#: The on-line S4 near S4 = 0 is the square root of a difference of moments that cancel, so an ulp of the
#: moments is a large part of S4 there: measured up to 1.4e-7 (1 ms, seeds 0-3), hence its own absolute
#: tolerance (a wrong S4 formula is off by 1e-2 or more).
S4_ATOL = 1e-6
#: outputs that are indices or epochs: equal
EXACT = ("ar_set", "cov_fail_epoch")


def _bits_equal(a, b) -> bool:
    """Every bit equal, except that a NaN equals any NaN.

    Where two NaNs meet in one operation (a NaN phase plus a NaN frequency step after the inf prompt) x86
    returns the first operand's and LLVM may swap the operands of an add or multiply: the sign of such a
    NaN is set by neither IEEE 754 nor LLVM.  Everything else (signs of zeros included) is compared as bits.
    """
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    if a.dtype != np.float64:
        return np.array_equal(a, b)
    nan_a, nan_b = np.isnan(a), np.isnan(b)
    return np.array_equal(nan_a, nan_b) and np.array_equal(a[~nan_a].view(np.uint64), b[~nan_b].view(np.uint64))


def _signal(ts: float, seed: int = 0):
    """Third-order dynamics plus a random-walk scintillation phase, a fading amplitude, 30 dB-Hz; the NaN, inf
    and zero prompts of the module docstring; a signal-free reference correlator (AEKF-AR option)."""
    rng = np.random.default_rng(seed)
    thd = third_order_phase(rng.uniform(-np.pi, np.pi, N), K, ts, 50.0, 100.0)
    rho = np.abs(1 + 0.4 * np.sin(np.arange(K) / 25.0))
    y = prompts(thd + np.cumsum(rng.normal(0, 0.03, (N, K)), axis=1), rho, complex_noise(seed, "lanes", range(N), K, noise_power(30.0, ts)))
    y[NAN_TRIAL, NAN_EPOCH] = complex(np.nan, np.nan)
    y[INF_TRIAL, INF_EPOCH] = complex(np.inf, 0.0)
    y[ZERO_TRIAL, ZERO_EPOCHS] = 0.0
    init = TrackInit(phase=np.angle(y[:, 0]), doppler_hz=np.full(N, 50.0), rate_hz_s=np.zeros(N),
                     noise_reference=complex_noise(seed, "lanes-reference", range(N), K, noise_power(30.0, ts)))
    return np.ascontiguousarray(y), init


SIGNALS = {ts: _signal(ts) for ts in (0.01, 0.001)}


def _sub(init: TrackInit, trials) -> TrackInit:
    def pick(a):
        return None if a is None or np.ndim(a) < 2 else a[trials]

    return TrackInit(init.phase[trials], init.doppler_hz[trials], init.rate_hz_s[trials], bit_prior=pick(init.bit_prior),
                     noise_reference=pick(init.noise_reference))


AR = {1: [0.95], 2: [1.6, -0.65], 3: [2.1, -1.5, 0.38]}
GAMMA = [1.8, -0.9, 0.05]
AR_SETS = [ScintillationAR.no_scintillation(), ScintillationAR.from_coefs([1.9, -0.91], GAMMA, 0.05, 4e-4, 1e-4, s4=0.5),
           ScintillationAR.from_coefs([0.99], GAMMA, 0.05, 4e-4, 1e-4, s4=0.9)]


def _tracker(name: str, ts: float):
    kf = dict(ts=ts, q_jerk=0.01, nominal_cn0_hz=1000.0, p0_diag=(0.25, 1.0, 1e4))
    susi = dict(kf, clock="ocxo", record=("discriminator", "frequency_hz", "R", "phi3", "T", "p", "weight"))
    scint = dict(scintillation=True, window_s=1.0, fit_band_hz=(0.5, 5.0)) if ts == 0.01 else dict(scintillation=True, window_s=0.1, fit_band_hz=(20.0, 200.0))
    aekf = dict(ts=ts, q_jerk=0.01, p0_diag=(0.25, 1.0, 1e4), nominal_noise=0.2)
    adaptive = dict(ar_sets=AR_SETS, adaptive=True, s4_window=100, s4_min_epochs=50, adapt_hold=20)
    record = ("theta_s", "rho_s", "s4_hat", "ar_set")
    return {
        "pll": lambda: PLL(ts=ts, bandwidth_hz=10.0),
        "pll_costas": lambda: PLL(ts=ts, bandwidth_hz=10.0, discriminator="atan"),
        "kf": lambda: KF(**kf),
        "kf_non_psd_p0": lambda: KF(**{**kf, "p0_diag": (0.25, -1.0, 1e4)}),
        "akf": lambda: AKF(**kf, adaptive_r=True),
        "akf_ar1": lambda: AKFAR(**kf, adaptive_r=True, ar_coefs=np.array(AR[1]), ar_sigma2=1e-3),
        "akf_ar2": lambda: AKFAR(**kf, adaptive_r=True, ar_coefs=np.array(AR[2]), ar_sigma2=1e-3),
        "akf_ar3": lambda: AKFAR(**kf, adaptive_r=True, ar_coefs=np.array(AR[3]), ar_sigma2=1e-3),
        "aekf_ar": lambda: AEKFAR(**aekf, ar_sets=AR_SETS[1:2], record=record),
        "aekf_ar_adaptive": lambda: AEKFAR(**aekf, **adaptive, record=record),
        "aekf_ar_fold": lambda: AEKFAR(**aekf, ar_sets=AR_SETS[1:2], fold_mirror=True, record=("rho_s", "theta_s")),
        "aekf_ar_floor_reference_noise": lambda: AEKFAR(**aekf, **adaptive, amplitude_floor=0.05, noise_estimate="reference", record=record),
        "aekf_ar_p1_q3": lambda: AEKFAR(**aekf, ar_sets=AR_SETS[2:], p_state=1, q_state=3, record=("rho_s",)),
        "aekf_ar_static": lambda: AEKFAR(ts=ts, q_jerk=0.0, p0_diag=(0.0, 0.0, 0.0), ar_sets=AR_SETS[1:2], nominal_noise=0.2),
        "susi_akf": lambda: SusiAKF(**susi, discriminator="atan"),
        "susi_akf_atan2": lambda: SusiAKF(**susi, discriminator="atan2"),
        "susi_akf_nominal_r": lambda: SusiAKF(**susi, discriminator="atan", adaptive_r=False),
        "susi_sakf": lambda: SusiSAKF(**susi, discriminator="atan2", **scint),
        "susi_sakf_hop7_weighted": lambda: SusiSAKF(**susi, discriminator="atan", **scint, update_s=7 * ts, weighting=GainWeighting(0.7, 0.3, 2.0)),
    }[name]()


TRACKERS = ["pll", "pll_costas", "kf", "kf_non_psd_p0", "akf", "akf_ar1", "akf_ar2", "akf_ar3", "aekf_ar", "aekf_ar_adaptive", "aekf_ar_fold",
            "aekf_ar_floor_reference_noise", "aekf_ar_p1_q3", "aekf_ar_static", "susi_akf", "susi_akf_atan2", "susi_akf_nominal_r", "susi_sakf",
            "susi_sakf_hop7_weighted"]


def _outputs(out) -> dict[str, np.ndarray]:
    return {"theta_d": out.theta_d, **{key: np.asarray(value) for key, value in out.extras.items()}}


def _assert_close_to_reference(fast: dict, ref: dict, label) -> None:
    assert fast.keys() == ref.keys(), label
    for key, a in fast.items():
        b = ref[key]
        if key in EXACT:
            np.testing.assert_array_equal(a, b, err_msg=f"{label} {key}")
        else:
            np.testing.assert_allclose(a, b, rtol=RTOL, atol=S4_ATOL if key == "s4_hat" else ATOL, equal_nan=True, err_msg=f"{label} {key}")


_RUNS: dict = {}


def _run(name: str, ts: float):
    """(outputs of ``run``, of ``reference``) on the 40 trials, computed once per module."""
    if (name, ts) not in _RUNS:
        tr = _tracker(name, ts)
        y, init = SIGNALS[ts]
        with np.errstate(invalid="ignore"):
            _RUNS[name, ts] = _outputs(tr.run(y, init)), _outputs(tr.reference(y, init))
    return _RUNS[name, ts]


@pytest.mark.parametrize("ts", sorted(SIGNALS))
@pytest.mark.parametrize("name", TRACKERS)
def test_lane_kernel_matches_the_reference(name, ts):
    fast, ref = _run(name, ts)
    _assert_close_to_reference(fast, ref, (name, ts))


@pytest.mark.parametrize("ts", sorted(SIGNALS))
@pytest.mark.parametrize("name", TRACKERS)
def test_a_trial_has_the_same_bits_in_every_batch(name, ts):
    whole, _ = _run(name, ts)
    tr = _tracker(name, ts)
    y, init = SIGNALS[ts]
    for n, trials in BATCHES.items():
        out = tr.run(y[trials], _sub(init, trials))
        if isinstance(tr, SusiSAKF):  # the monitors are held per refresh period
            assert all(isinstance(out.extras[m], HeldSeries) for m in ("phi3", "T", "p", "weight"))
        part = _outputs(out)
        assert part.keys() == whole.keys()
        for key, value in part.items():
            assert _bits_equal(value, whole[key][trials]), (name, ts, n, key)


@pytest.mark.parametrize("ts", sorted(SIGNALS))
@pytest.mark.parametrize("name", TRACKERS)
def test_non_finite_and_zero_prompts_stay_in_their_trial(name, ts):
    """NaN and inf prompts make their trial's estimates NaN from that epoch on (the PLL's phase one epoch
    later: its output is the NCO phase that correlated the epoch), never before; zero prompts (no signal, no
    noise) leave every estimate finite; the other trials are untouched (their bits: the batch test)."""
    fast, ref = _run(name, ts)
    theta = fast["theta_d"]
    delay = 1 if name.startswith("pll") else 0
    for trial, epoch in ((NAN_TRIAL, NAN_EPOCH), (INF_TRIAL, INF_EPOCH)):
        assert np.isfinite(theta[trial, : epoch + delay]).all() and np.isnan(theta[trial, epoch + delay :]).all(), (name, trial)
    assert np.isfinite(theta[ZERO_TRIAL]).all()
    others = np.setdiff1d(np.arange(N), [NAN_TRIAL, INF_TRIAL])
    assert np.isfinite(theta[others]).all()
    if "cov_fail_epoch" in fast:
        fail = fast["cov_fail_epoch"]
        np.testing.assert_array_equal(fail, ref["cov_fail_epoch"])
        if name == "kf_non_psd_p0":
            assert (fail == 0).all()  # P0 fails the test at epoch 0 in every trial
            return
        if name in ("kf", "susi_akf_nominal_r"):  # fixed R: P does not see the prompts, a NaN estimate with a sound P
            expected = (-1, -1)
        elif name.startswith("aekf_ar"):  # R from the prompts' M2M4 makes P NaN; P is tested every 16 epochs
            expected = (-(-NAN_EPOCH // 16) * 16, -(-INF_EPOCH // 16) * 16)
        else:  # R from the M2M4 C/N0: NaN at the NaN (inf) prompt's epoch, and P with it
            expected = (NAN_EPOCH, INF_EPOCH)
        assert (fail[NAN_TRIAL], fail[INF_TRIAL]) == expected, name
        assert (fail[others] == -1).all()


#: trackers that divide by the M2M4 powers of their prompt window: the C/N0 of R (KF, Susi) or of the
#: on-line S4's noise correction (adaptive AEKF-AR with the M2M4 noise power)
DIVIDE_BY_WINDOW = {"akf", "akf_ar1", "akf_ar2", "akf_ar3", "aekf_ar_adaptive", "susi_akf", "susi_akf_atan2", "susi_sakf", "susi_sakf_hop7_weighted"}


@pytest.mark.parametrize("name", TRACKERS)
def test_a_whole_window_of_zero_prompts(name):
    """Prompts exactly zero over a whole M2M4 window (a dead channel; never met with noise): where the filter
    divides by the window's powers (0 / 0) the kernel raises ZeroDivisionError, numba's scalar division, rather
    than carry NaN (the numpy reference returns NaN there, or numpy.linalg's LinAlgError); the other filters
    stay finite."""
    ts = 0.01
    y, init = SIGNALS[ts]
    y = y.copy()
    y[ZERO_TRIAL, 100:300] = 0.0
    tr = _tracker(name, ts)
    if name in DIVIDE_BY_WINDOW:
        with pytest.raises(ZeroDivisionError):
            tr.run(y, init)
    else:
        assert np.isfinite(tr.run(y, init).theta_d[ZERO_TRIAL]).all()


def test_the_adaptive_aekf_ar_switches_sets():
    """The adaptive reference comparison covers a switch of the AR set (and its S4 hold)."""
    for ts in SIGNALS:
        sets = _run("aekf_ar_floor_reference_noise", ts)[0]["ar_set"]
        assert len(np.unique(sets)) > 1


def test_the_sakf_refreshes_its_scintillation_blocks():
    for ts in SIGNALS:
        fast, _ = _run("susi_sakf", ts)
        assert np.isfinite(fast["p"][:, -1]).sum() >= N - 2  # the refresh ran (NaN only in the NaN / inf trials)


# --- Susi et al.: the kernel's state carried across calls ------------------------------------------------------


@pytest.mark.parametrize("costas", [True, False])
def test_susi_kernel_over_irregular_chunks(costas):
    """Direct kernel calls over an irregular chunk schedule (single epochs, a chunk across the M2M4 lap, the
    rest).  With fixed PSDs and weights the chunks give the bits of one call; with new per-trial PSDs and
    weights in every chunk each trial, and its carried state, has the same bits in every batch."""
    ts = 0.01
    y, init = SIGNALS[ts]
    tr = SusiAKF(ts=ts, clock="rubidium", q_jerk=0.02, nominal_cn0_hz=800.0, p0_diag=(0.25, 1.0, 1e4), discriminator="atan" if costas else "atan2")
    prm = tr.params()
    bounds = [0, 1, 2, 3, 17, 49, 50, 51, 130, 131, 250, K]
    rng = np.random.default_rng(5)
    psds = [(rng.exponential(1e-3, N), rng.exponential(1e-4, N), rng.uniform(0.3, 1.2, N)) for _ in bounds[:-1]]

    def chunks(trials, schedule, changing):
        n = len(trials)
        st = susi_state(initial_state(_sub(init, trials), 3), prm.P0, prm.window)
        outs = [np.empty((n, K)) for _ in range(4)] + [np.full(n, -1, dtype=np.int64)]
        for c, (i0, i1) in enumerate(zip(schedule[:-1], schedule[1:])):
            s_phi, s_f, weight = (v[trials] for v in psds[c if changing else 0])
            susi_kernel(y[trials], i0, i1, prm, st, s_phi, s_f, weight, *outs)
        return outs, st

    everything = list(range(N))
    one_call, _ = chunks(everything, [0, K], changing=False)
    for a, b in zip(chunks(everything, bounds, changing=False)[0], one_call):
        assert _bits_equal(a, b)
    whole, st = chunks(everything, bounds, changing=True)
    for n, trials in BATCHES.items():
        part, st_part = chunks(trials, bounds, changing=True)
        for a, b in zip(part, whole):
            assert _bits_equal(a, b[trials]), n
        lane_x = st.x.transpose(0, 2, 1).reshape(-1, 3)[trials]  # trial c0 + ln is lane ln of block c0 / LANES
        assert _bits_equal(np.ascontiguousarray(st_part.x.transpose(0, 2, 1).reshape(-1, 3)[:n]), np.ascontiguousarray(lane_x))
        lane_p = st.P.transpose(0, 3, 1, 2).reshape(-1, 3, 3)[trials]
        assert _bits_equal(np.ascontiguousarray(st_part.P.transpose(0, 3, 1, 2).reshape(-1, 3, 3)[:n]), np.ascontiguousarray(lane_p))


# --- Zhao et al.: the MM filter --------------------------------------------------------------------------------

MM_TS = 0.02


def _mm_signal(seed: int = 3):
    """Data bits on a random-walk phase at 30 dB-Hz (20-ms sums), and the three kinds of bit priors."""
    rng = np.random.default_rng(seed)
    phi = rng.uniform(-np.pi, np.pi, (N, 1)) + np.cumsum(rng.normal(0, 0.02, (N, K)), axis=1)
    bits = rng.choice([-1.0, 1.0], (N, K))
    y = bits * np.exp(1j * phi) + complex_noise(seed, "lanes-mm", range(N), K, noise_power(30.0, MM_TS))
    mixed = np.where(rng.random((N, K)) < 0.3, (bits > 0).astype(float), rng.choice([0.5, 0.8, 0.2], (N, K)))
    priors = {"pilot": None, "unknown": np.full((N, K), 0.5), "mixed": mixed}
    return np.ascontiguousarray(y), bits, phi, priors


MM_Y, MM_BITS, MM_PHI, MM_PRIORS = _mm_signal()


def _mm_init(priors: str, trials=slice(None)) -> TrackInit:
    prior = MM_PRIORS[priors]
    n = len(MM_PHI[trials])
    return TrackInit(phase=MM_PHI[trials, 0], doppler_hz=np.zeros(n), rate_hz_s=np.zeros(n), bit_prior=None if prior is None else prior[trials])


def _mm_prompts(priors: str) -> np.ndarray:
    return np.ascontiguousarray(MM_Y * MM_BITS) if priors == "pilot" else MM_Y  # a pilot: the bits wiped off


MM_CASES = [(priors, r) for priors in ("pilot", "unknown", "mixed") for r in ("m2m4", 0.3)]


@pytest.mark.parametrize(("priors", "r"), MM_CASES)
def test_mm_lane_loop_matches_the_reference_and_every_batch(priors, r):
    """Pilot, unknown (1/2) and mixed priors (known bits of either sign give the log-sum-exp's -inf branches),
    sliding-M2M4 and fixed R: within the tolerance of the reference, and the same bits in every batch."""
    tr = MMKF(ts=MM_TS, r=r, m2m4_window=40)
    y = _mm_prompts(priors)
    fast = _outputs(tr.run(y, _mm_init(priors)))
    _assert_close_to_reference(fast, _outputs(tr.reference(y, _mm_init(priors))), (priors, r))
    assert np.isfinite(fast["theta_d"]).all() and (fast["cov_fail_epoch"] == -1).all()
    for n, trials in BATCHES.items():
        part = _outputs(tr.run(y[trials], _mm_init(priors, trials)))
        for key, value in part.items():
            assert _bits_equal(value, fast[key][trials]), (priors, r, n, key)


def _mm_loop(tr, y, init, start=None, previous=None):
    """(theta, freq, amp, p_plus, log_odds, cn0, covariance, cov_fail) of :func:`mm_kf_loop` from ``start``
    (default 0), on copies of ``previous``' arrays (a resume) or new ones."""
    n, k = y.shape
    arrays = [np.empty((n, k)) for _ in range(6)] + [np.empty((n, k, len(COV_ENTRIES))), np.full(n, -1, dtype=np.int64)]
    if previous is not None:
        arrays = [a.copy() for a in previous]
    mm_kf_loop(y, tr.params(y, init), np.zeros(n, dtype=np.int64) if start is None else start, *arrays)
    return arrays


@pytest.mark.parametrize("r", ["m2m4", 0.3])
def test_mm_lane_loop_resumed_and_on_non_finite_prompts(r):
    """The loop resumed from a different epoch per trial (0, inside the M2M4 start-up window, later, the last,
    past the end) has the bits of a run from epoch 0 with the new priors, in every batch.  ``run`` refuses
    NaN and inf prompts; the loop itself keeps them in their trial: NaN from that epoch on there, the other
    trials' bits unchanged."""
    tr = MMKF(ts=MM_TS, r=r, m2m4_window=40)
    y = MM_Y
    old = _mm_init("unknown")
    before = _mm_loop(tr, y, old)
    rng = np.random.default_rng(11)
    start = rng.choice([0, 1, 25, 200, K - 1, K + 5], N).astype(np.int64)
    # new priors from each trial's start on (before it, the old ones: what the resume assumes)
    prior = np.where(np.arange(K)[None, :] < start[:, None], MM_PRIORS["unknown"], MM_PRIORS["mixed"])
    new = TrackInit(old.phase, old.doppler_hz, old.rate_hz_s, bit_prior=prior)
    target = _mm_loop(tr, y, new)
    resumed = _mm_loop(tr, y, new, start, before)
    for j, (a, b) in enumerate(zip(resumed, target)):
        assert _bits_equal(a, b), j
    for n, trials in BATCHES.items():
        part = _mm_loop(tr, y[trials], _sub(new, trials), start[trials], [a[trials] for a in before])
        for j, (a, b) in enumerate(zip(part, resumed)):
            assert _bits_equal(a, b[trials]), (n, j)

    bad = y.copy()
    bad[NAN_TRIAL, NAN_EPOCH] = complex(np.nan, np.nan)
    bad[INF_TRIAL, INF_EPOCH] = complex(np.inf, 0.0)
    with pytest.raises(ValueError, match="NaN or inf"):
        tr.run(bad, old)
    clean = _mm_loop(tr, y, old)
    with np.errstate(invalid="ignore"):
        dirty = _mm_loop(tr, bad, old)
    others = np.setdiff1d(np.arange(N), [NAN_TRIAL, INF_TRIAL])
    for a, b in zip(dirty, clean):
        assert _bits_equal(a[others], b[others])
    for trial, epoch in ((NAN_TRIAL, NAN_EPOCH), (INF_TRIAL, INF_EPOCH)):
        assert np.isfinite(dirty[0][trial, :epoch]).all() and np.isnan(dirty[0][trial, epoch:]).all()
        assert dirty[7][trial] == epoch  # the covariance test fails where R (or the state) becomes NaN


# --- the lane blocks' division by zero ---------------------------------------------------------------------------


def test_a_zero_innovation_variance_on_any_lane_raises():
    """IEEE would give inf or NaN on that lane and go on; the lane updates raise ZeroDivisionError as numba's
    scalar division does, so a degenerate filter is never silently carried."""
    H = np.array([1.0, 0.0, 0.0])
    x, P, PH = blocks.lanes_empty((3, L)), blocks.lanes_empty((3, 3, L)), blocks.lanes_empty((3, L))
    x[:], P[:] = 0.0, 0.0
    P[0, 0, :] = 1.0
    P[0, 0, 7] = 0.0  # one lane with S = H P H^T + R = 0
    R, nu, w = np.zeros(L), np.full(L, 0.1), np.ones(L)
    with pytest.raises(ZeroDivisionError):
        blocks.scalar_update_lanes(x, P, PH, H, R, nu)
    with pytest.raises(ZeroDivisionError):
        blocks.weighted_scalar_update_lanes(x, P, PH, H, R, nu, w)
    P[0, 0, 7] = 1.0
    blocks.scalar_update_lanes(x, P, PH, H, R, nu)  # no zero lane: no error
    np.testing.assert_array_equal(x[0], 0.1)
    # the MM filter's 2 x 2 S: det S = 0 on one lane (zero P, zero R)
    xm, Pm = blocks.lanes_empty((3, L)), blocks.lanes_empty((3, 3, L))
    xm[:], Pm[:] = 1.0, 0.0
    for a in range(3):
        Pm[a, a, :] = 0.1
    Pm[:, :, 5] = 0.0
    work = [blocks.lanes_empty((3, L)) for _ in range(5)] + [blocks.lanes_empty((L,)) for _ in range(2)]
    r = np.zeros(L)
    lanes = [np.full(L, v) for v in (1.0, 0.0, 0.0, -np.inf)]
    with pytest.raises(ZeroDivisionError):
        two_mode_iq_update_lanes(xm, Pm, *work, r, *lanes, blocks.lanes_empty((L,)), blocks.lanes_empty((L,)))
