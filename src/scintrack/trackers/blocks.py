"""The numba building blocks every tracker kernel is made of (each formula once).

Vila-Valls et al. 2018 (Sec. IV-V) equations and the block that implements them:

* eq. (8), (11) prediction ``x <- F x (+ kappa)``, ``P <- F P F^T + Q`` with
  the block-diagonal F given by its non-zeros: :func:`predict` (and
  :func:`nonzeros` to list them); the same for F = blkdiag(dynamics, AR
  companion, AR companion) using that structure, on lanes (below):
  :func:`ar_predict` (and :func:`ar_coefficients`);
* scalar measurement update (discriminator KFs, ``H = [1, 0, 0, (1, 0..)]``,
  Sec. V-A): :func:`scalar_update` (its ``P H^T`` and ``S``: :func:`innovation_terms`);
  with a weighted gain and the Joseph covariance (Susi 2014, eq. 12):
  :func:`weighted_scalar_update`; Susi's eq. (10) R: :func:`costas_variance`;
  the (phase, frequency) white-noise Q of Susi's eqs. (3)-(8): :func:`phase_frequency_q`;
* eqs. (13)-(14) I/Q (2 x 2) EKF update with the Jacobian of ``h(x) = A rho_s
  [cos(theta_d + theta_s), sin(theta_d + theta_s)]`` in closed form, on lanes:
  :func:`iq_update`;
* ATAN2 discriminator ``atan2(Q, I)`` of the prompt against the replica phase:
  :func:`atan2_discriminator`; its data-insensitive (Costas) form ``atan(Q/I)``:
  :func:`atan_discriminator`;
* eq. (12) discriminator variance at ``x = 2 C/N0 Ts``: :func:`atan_variance`;
* M2M4 signal/noise split (GNSS-SDR ``cn0_m2m4_estimator``):
  :func:`m2m4_signal_power`, :func:`m2m4_split`; C/N0 from the powers:
  :func:`cn0_from_powers`;
* sliding-window running sums (ring buffers, exact re-sum once per lap):
  :func:`window_push` (on lanes: :func:`window_push_lanes`), window moments
  :func:`window_mean_var`;
* noise-corrected S4 from intensity moments (Sec. V-B), NaN when not
  estimable: :func:`s4_corrected`; the lane-wise select it is made with
  (numbers and Lanes alike): :func:`select_less`;
* nearest adaptation point (Sec. V-B): :func:`nearest_index` (on lanes:
  :func:`nearest_index_lanes`);
* the mirror fold of the AEKF-AR (an isolating option, not in the paper):
  :func:`fold_mirror`; periodic symmetrisation of P: :func:`symmetrise`;
* the divergence guard's covariance test (finite, non-negative phase and
  frequency variances, 2 x 2 minor >= 0): :func:`covariance_ok`;
* third-order PLL loop filter (Kaplan & Hegarty): :func:`pll_constants`,
  :func:`pll_step`.

Every block is an ``@njit`` function: the kernels call them (numba inlines
them; the expressions are written exactly as in the original kernels so the
compiled arithmetic, hence every bit of the results, is unchanged; never turn
fastmath on here).  Plain Python can call them on scalars, and the
array-valued formulas used by the vectorised numpy estimators
(:mod:`scintrack.estimators`) are ``numba.vectorize`` ufuncs compiled from the
*same* Python function (``*_ufunc`` below), so no formula is written twice.

Lanes (:mod:`.simd`, used from the middle of this module on): ``LANES`` trials side by side as one SIMD vector per
matrix entry (``Lanes``, an LLVM ``<LANES x double>``), for kernels that run
trials in blocks (the AEKF-AR).  Its operators are IEEE per lane exactly as
numba lowers the scalar ones, so the scalar blocks (``m2m4_split``,
``window_mean_var``, ``s4_corrected``, ...) compile unchanged for ``Lanes``
arguments and give, lane by lane, the bits of the scalar call
(``tests/test_trackers.py::test_lane_blocks_are_the_scalar_blocks_bit_for_bit``).
The discriminator KFs, the Susi KF PLLs and the PLL run on lanes too (issue 14,
third round), with the lane forms of the blocks above: :func:`sparse_predict_lanes`
(:func:`predict`), :func:`innovation_terms_lanes`, :func:`scalar_update_lanes`,
:func:`weighted_scalar_update_lanes`, :func:`atan2_discriminator_lanes` and
:func:`atan_discriminator_lanes` (the scalar discriminator compiled for Lanes: its
sine, cosine and arctangent are :mod:`.trig`'s, plain IEEE arithmetic, since the
twenty-second round of issue 14; with the gather of the epoch's prompts:
:func:`prompt_discriminator_lanes`),
:func:`m2m4_lanes` (on :func:`window_push_lanes`), and
:func:`lanes_any_zero` (the scalar division's ZeroDivisionError on any lane);
the trial of each lane of a block of trials: :func:`lane_trials`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, vectorize

from . import trig
from .lanes import LANES
from .simd import (
    lane_load,
    lane_splat,
    lane_store,
    lane_where_less,
    lanes_any_zero,
    lanes_empty,  # noqa: F401 - the kernels call it as blocks.lanes_empty
    select_less,
)

_F8_2 = ["float64(float64, float64)"]
_F8_3 = ["float64(float64, float64, float64)"]


class _Ufunc:
    """``numba.vectorize(signatures)(py)``, built on first call (keeps imports cheap).

    The ufunc is built from a copy of ``py`` named ``<name>_ufunc``, so that its
    entries live in a numba cache file of their own.  numba names a cache file
    after the function's qualified name and first line, so ``njit(cache=True)``
    and ``vectorize(cache=True)`` of the same function shared one index, in
    which the ufunc's element kernel and the compiled function had the same
    argument types; the job server's :func:`~scintrack.pipeline.job_server.load_cached_kernels`
    then loaded the element kernel as the ``njit`` function's overload, and a
    call from Python crashed (SIGSEGV, issue 14, sixteenth round).
    """

    def __init__(self, py, signatures):
        self.py, self.signatures, self._ufunc = py, signatures, None
        self.__doc__ = f"Array (ufunc) form of :func:`{py.__name__.lstrip('_')}`."

    def build(self) -> None:
        """Build the ufunc now (its element kernel from the numba cache, its loop wrapper compiled: ~60 ms
        that numba does not cache).  The job server builds every one before it forks (issue 14)."""
        if self._ufunc is None:
            self._ufunc = vectorize(self.signatures, cache=True)(_renamed(self.py, "_ufunc"))

    def __call__(self, *args):
        self.build()
        return self._ufunc(*args)


def _renamed(py, suffix: str):
    """A copy of the function ``py`` (same code, globals, defaults) whose name and qualified name end in ``suffix``."""
    import types as pytypes

    f = pytypes.FunctionType(py.__code__, py.__globals__, py.__name__ + suffix, py.__defaults__, py.__closure__)
    f.__qualname__ = py.__qualname__ + suffix
    f.__module__ = py.__module__
    f.__doc__ = py.__doc__
    return f


# --- eq. (12): discriminator variance ---------------------------------------


def _atan_variance(cn0_hz, ts):
    x = max(2.0 * cn0_hz * ts, 1e-6)
    return (math.exp(-0.8 * math.sqrt(x)) + 1.0) * math.erf(0.4 * x) / x


atan_variance = njit(cache=True)(_atan_variance)
atan_variance_ufunc = _Ufunc(_atan_variance, _F8_2)


# --- ATAN2 discriminator --------------------------------------------------------


def _atan2_discriminator(yr, yi, phase):
    s_, c_ = trig.sincos(phase)
    return trig.atan2(yi * c_ - yr * s_, yr * c_ + yi * s_)


atan2_discriminator = njit(cache=True)(_atan2_discriminator)
atan2_discriminator_ufunc = _Ufunc(_atan2_discriminator, _F8_3)


def _atan_discriminator(yr, yi, phase):
    """Costas (two-quadrant) ``atan(Q/I)``: insensitive to the data bit, error in [-pi/2, pi/2] (``I = 0``: +-pi/2)."""
    s_, c_ = trig.sincos(phase)
    i_ = yr * c_ + yi * s_
    q_ = yi * c_ - yr * s_
    return trig.atan(q_, i_)


atan_discriminator = njit(cache=True)(_atan_discriminator)
atan_discriminator_ufunc = _Ufunc(_atan_discriminator, _F8_3)


# --- M2M4 and C/N0 ---------------------------------------------------------------


def _m2m4_signal_power(m2, m4, floor_fraction):
    pd = math.sqrt(max(2.0 * m2 * m2 - m4, (floor_fraction * m2) ** 2))
    return min(pd, (1.0 - floor_fraction) * m2)


m2m4_signal_power = njit(cache=True)(_m2m4_signal_power)
m2m4_signal_power_ufunc = _Ufunc(_m2m4_signal_power, _F8_3)


@njit(cache=True)
def m2m4_split(m2, m4, floor_fraction):
    """(signal power, noise power) from the 2nd and 4th moments of |P|."""
    pd = m2m4_signal_power(m2, m4, floor_fraction)
    return pd, m2 - pd


def _cn0_from_powers(signal_power, noise_power, ts):
    return signal_power / (noise_power * ts)


cn0_from_powers = njit(cache=True)(_cn0_from_powers)
cn0_from_powers_ufunc = _Ufunc(_cn0_from_powers, _F8_3)


# --- sliding windows and S4 ------------------------------------------------------


@njit(cache=True)
def window_push(b1, b2, pos, s1, s2, count, v1, v2):
    """Push (v1, v2) into two ring buffers with running sums; exact re-sum once per lap."""
    s1 += v1 - b1[pos]
    s2 += v2 - b2[pos]
    b1[pos] = v1
    b2[pos] = v2
    pos = (pos + 1) % b1.size
    count = min(count + 1, b1.size)
    if pos == 0:
        s1 = b1.sum()
        s2 = b2.sum()
    return pos, s1, s2, count


def _window_variance(s1, s2, count):
    mean = s1 / count
    return max(s2 / count - mean * mean, 0.0)


window_variance = njit(cache=True)(_window_variance)
window_variance_ufunc = _Ufunc(_window_variance, _F8_3)


@njit(cache=True)
def window_mean_var(s1, s2, count):
    """Mean and (floored) variance from the window sums of x and x^2."""
    return s1 / count, window_variance(s1, s2, count)


#: "not estimable" below: the signal power ``mean(I) - s2`` is at most this fraction of the noise power ``s2``
S4_SIGNAL_FRACTION = 0.1
#: "not estimable" at and above: an S4 no fading model reaches (Nakagami-m, m >= 1/2: S4 <= sqrt 2)
S4_ESTIMABLE_MAX = 2.0


def _s4_corrected(mean_i, var_i, noise_power):
    """Noise-corrected S4 (:mod:`scintrack.estimators.s4`), NaN when not estimable.

    ``S4^2 = (var_i - 2 S s2 - s2^2) / S^2`` with ``S = mean_i - s2`` (floored
    at 1e-12, a negative ``S4^2`` floored at 0, as always).  NaN ("not
    estimable") when

    * ``S <= S4_SIGNAL_FRACTION * s2`` (0.1): the signal part of the intensity
      variance, ``S^2 S4^2 <= 0.01 s2^2`` even at S4 = 1, is below the sampling
      error of the variance of a noise-dominated intensity, ``~ s2^2
      sqrt(8 / N)``, for every window shorter than N = 8e4 epochs (the
      on-line window is 1e3-1e4); below it the estimate is noise (at 10
      dB-Hz and 10 ms, ``S / s2 = 0.1``; the 1e-12 floor alone gave S4 up to
      2.7e12);
    * the S4 is NaN or ``>= S4_ESTIMABLE_MAX`` (2): above any fading model
      (Nakagami-m with m >= 1/2, the family's limit, has S4 <= sqrt 2 = 1.41;
      the CSM realises S4 <= 1, the phase screen saturates near 1), with a
      margin of 40 % for the sampling error of a window estimate.

    Wherever neither applies the value is bit for bit the former one.  The
    tests are :func:`select_less` (ordered compares: a NaN input fails them
    and gives NaN), so the same formula compiles for Lanes.
    """
    sig = max(mean_i - noise_power, 1e-12)
    s4sq = (var_i - 2.0 * sig * noise_power - noise_power * noise_power) / (sig * sig)
    s4 = math.sqrt(max(s4sq, 0.0))
    return select_less(S4_SIGNAL_FRACTION * noise_power, sig, select_less(s4, S4_ESTIMABLE_MAX, s4, math.nan), math.nan)


s4_corrected = njit(cache=True)(_s4_corrected)
s4_corrected_ufunc = _Ufunc(_s4_corrected, _F8_3)


@njit(cache=True)
def nearest_index(value, points):
    """Index of the point nearest to ``value`` (the first one on ties)."""
    best = 0
    for j in range(points.size):
        if abs(value - points[j]) < abs(value - points[best]):
            best = j
    return best


# --- Kalman filter steps ------------------------------------------------------------


def nonzeros(F: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Non-zero entries of a stack of transition matrices (S, n, n), padded.

    F is block-diagonal with companion blocks, so ~16 of its 81 entries are
    non-zero; :func:`predict` loops over those only.
    """
    F = F if F.ndim == 3 else F[None]
    counts = np.array([np.count_nonzero(f) for f in F], dtype=np.int64)
    m = int(counts.max()) if counts.size else 0
    rows = np.zeros((F.shape[0], m), dtype=np.int64)
    cols = np.zeros((F.shape[0], m), dtype=np.int64)
    vals = np.zeros((F.shape[0], m))
    for j, f in enumerate(F):
        r, c = np.nonzero(f)
        rows[j, : r.size], cols[j, : r.size], vals[j, : r.size] = r, c, f[r, c]
    return rows, cols, vals, counts


@njit(cache=True)
def predict(x, P, xp, FP, Q, kap, rows, cols, vals, count, use_kap):
    """x <- F x (+ kappa), P <- F P F^T + Q with F given by its non-zeros (eqs. 8, 11)."""
    n = x.size
    for a in range(n):
        xp[a] = kap[a] if use_kap else 0.0
    FP[:, :] = 0.0
    for m in range(count):
        a, c, v = rows[m], cols[m], vals[m]
        xp[a] += v * x[c]
        for b in range(n):
            FP[a, b] += v * P[c, b]
    x[:] = xp
    P[:, :] = Q
    for m in range(count):
        b, c, v = rows[m], cols[m], vals[m]
        for a in range(n):
            P[a, b] += v * FP[a, c]


@njit(cache=True)
def innovation_terms(P, H, R, PH):
    """``PH = P H^T`` (written into ``PH``) and the innovation variance ``S = H P H^T + R`` of a scalar measurement."""
    n = PH.size
    S = R
    for a in range(n):
        acc = 0.0
        for b in range(n):
            acc += P[a, b] * H[b]
        PH[a] = acc
        S += H[a] * acc
    return S


@njit(cache=True)
def scalar_update(x, P, PH, H, R, nu):
    """Scalar measurement: S = H P H^T + R, K = P H^T / S, x += K nu, P -= K (P H^T)^T."""
    n = x.size
    S = innovation_terms(P, H, R, PH)
    for a in range(n):
        x[a] += PH[a] / S * nu
    for a in range(n):
        ka = PH[a] / S
        for b in range(n):
            P[a, b] -= ka * PH[b]


@njit(cache=True)
def fold_mirror(x, P, ir):
    """(rho, theta_s) -> (-rho, theta_s + pi) on every lag; P -> J P J."""
    n = x.size
    for a in range(3, ir):
        x[a] += math.pi
    for a in range(ir, n):
        x[a] = -x[a]
        for b in range(ir):
            P[a, b] = -P[a, b]
            P[b, a] = -P[b, a]


@njit(cache=True)
def symmetrise(P):
    n = P.shape[0]
    for a in range(n):
        for b in range(a + 1, n):
            m = 0.5 * (P[a, b] + P[b, a])
            P[a, b] = m
            P[b, a] = m


#: relative slack of the Cauchy-Schwarz test of :func:`covariance_ok` (rounding of a strongly correlated pair)
COV_CORRELATION_SLACK = 1e-6


def _covariance_ok(paa, pbb, pab):
    """The cheapest meaningful positive-(semi)definiteness test of a covariance, on one pair of states.

    ``paa``, ``pbb``: the variances of the phase and the frequency state;
    ``pab`` their covariance.  Passes when both variances are finite and
    >= 0 and ``pab^2 <= paa pbb (1 + COV_CORRELATION_SLACK)`` (the 2 x 2
    principal minor >= 0, Cauchy-Schwarz): necessary conditions of a positive
    semi-definite P, three loads and a few compares per epoch.  An exact zero
    variance passes (a state known exactly, e.g. the static AEKF-AR's
    dynamics block with P0 = Q = 0); a NaN or inf anywhere in the pair fails
    (every comparison with NaN is false).  The slack allows the rounding of a
    pair correlated to within 1e-6 of 1; a filter that has truly lost positive
    definiteness violates it by orders of magnitude.  Read-only: the kernels
    call it on the updated P and record the first failing epoch per trial
    (``extras["cov_fail_epoch"]``, -1 none), which
    :mod:`scintrack.experiments.guards` turns into a divergence flag.
    """
    if not (paa >= 0.0 and pbb >= 0.0 and paa < math.inf and pbb < math.inf):
        return False
    return pab * pab <= paa * pbb * (1.0 + COV_CORRELATION_SLACK)


covariance_ok = njit(cache=True)(_covariance_ok)
covariance_ok_ufunc = _Ufunc(_covariance_ok, ["boolean(float64, float64, float64)"])


# --- third-order PLL loop filter ------------------------------------------------

PLL_A3, PLL_B3, PLL_BN_PER_W0 = 1.1, 2.4, 0.7845


@njit(cache=True)
def pll_constants(bandwidth_hz, ts):
    """Gains of the bilinear loop filter: (T w0^3, a3 w0^2, b3 w0), w0 = Bn / 0.7845."""
    w0 = bandwidth_hz / PLL_BN_PER_W0
    return ts * w0**3, PLL_A3 * w0**2, PLL_B3 * w0


@njit(cache=True)
def pll_step(phase, v, w, e, k3, k2, k1, ts):
    """One loop-filter and NCO step; works on scalars and (trial) arrays.

    ``w_k = w_{k-1} + T w0^3 e``, ``v_k = v_{k-1} + T ((w_k + w_{k-1})/2 + a3 w0^2 e)``,
    ``f = (v_k + v_{k-1})/2 + b3 w0 e``, next phase ``phase + f T``.
    """
    w_new = w + k3 * e
    v_new = v + ts * (0.5 * (w_new + w) + k2 * e)
    f = 0.5 * (v_new + v) + k1 * e
    return phase + f * ts, v_new, w_new


# --- Susi et al. 2014: eq. (10) R, the (phase, frequency) process noise, weighted gain --


def _costas_variance(cn0_hz, ts):
    """Susi eq. (10): ``R = 1/(2 C/N0 Ts) (1 + 1/(2 C/N0 Ts))`` [rad^2], the atan discriminator's variance."""
    x = max(2.0 * cn0_hz * ts, 1e-6)
    return (1.0 + 1.0 / x) / x


costas_variance = njit(cache=True)(_costas_variance)
costas_variance_ufunc = _Ufunc(_costas_variance, _F8_2)


@njit(cache=True)
def phase_frequency_q(s_phi, s_f, ts, out):
    """Discrete Q of the state [phase (rad), frequency (Hz), rate] from white noises on
    the phase (PSD ``s_phi``, rad^2/s) and on the frequency (``s_f``, Hz^2/s) of the
    continuous model ``dphi/dt = 2 pi f + w_phi``, ``df/dt = a + w_f`` (Susi eqs. 3-4):

    ``Q00 = s_phi T + (2 pi)^2 s_f T^3 / 3``, ``Q01 = 2 pi s_f T^2 / 2``, ``Q11 = s_f T``
    (added to ``out``, a 3 x 3 array).  The same matrix as
    :func:`scintrack.models.clock.process_noise` for a clock, in (rad, Hz).
    """
    c = 2.0 * math.pi
    out[0, 0] += s_phi * ts + c * c * s_f * ts**3 / 3.0
    out[0, 1] += c * s_f * ts**2 / 2.0
    out[1, 0] += c * s_f * ts**2 / 2.0
    out[1, 1] += s_f * ts


@njit(cache=True)
def weighted_scalar_update(x, P, PH, H, R, nu, w):
    """Scalar update with the gain weighted by ``w`` (Susi eq. 12, ``K' = w K``).

    ``S = H P H^T + R``, ``K = P H^T / S``, ``x += w K nu``, and the Joseph form
    ``P = (I - w K H) P (I - w K H)^T + w^2 K R K^T``, which for a scalar
    measurement is ``P -= (2 w - w^2) (P H^T)(P H^T)^T / S`` (the covariance of
    the weighted, suboptimal filter; ``w = 1`` is the ordinary update).
    """
    n = x.size
    S = innovation_terms(P, H, R, PH)
    g = (2.0 * w - w * w) / S
    for a in range(n):
        x[a] += w * PH[a] / S * nu
    for a in range(n):
        for b in range(n):
            P[a, b] -= g * PH[a] * PH[b]


# rows of the per-set coefficient table of ar_predict (ar_coefficients)
C_F01, C_F02, C_F12 = 0, 1, 2  # F_d[0, 1], F_d[0, 2], F_d[1, 2]
C_QD = 3  # Q_d, 9 entries row-major
C_QT, C_QR, C_KAP = 12, 13, 14  # Q[3, 3], Q[ir, ir], kappa (on the rho_s,k row)
C_AR = 15  # beta_1..beta_p, then gamma_1..gamma_q


def ar_coefficients(F: np.ndarray, Q: np.ndarray, kap: np.ndarray, p: int, q: int) -> np.ndarray:
    """Per-set coefficient rows (sets, C_AR + p + q) of :func:`ar_predict`, from stacked F, Q, kappa.

    Checks that F is ``blkdiag(F_d, companion(beta), companion(gamma))`` with
    ``F_d`` upper triangular with a unit diagonal (eq. 8), that Q is
    ``blkdiag(Q_d, sigma_theta^2, 0.., sigma_rho^2, 0..)`` and that kappa sits on
    the rho_s,k row only (eq. 11): the structure :func:`ar_predict` assumes.
    """
    F, Q, kap = (np.asarray(a, dtype=float) for a in (F, Q, kap))
    n, ir = 3 + p + q, 3 + p
    if p < 1 or q < 1:
        raise ValueError(f"the state needs at least one phase and one amplitude lag (p = {p}, q = {q})")
    if F.ndim != 3 or F.shape[1:] != (n, n) or Q.shape != F.shape or kap.shape != F.shape[:2]:
        raise ValueError(f"F, Q, kappa must be (sets, {n}, {n}), (sets, {n}, {n}), (sets, {n})")
    co = np.zeros((F.shape[0], C_AR + p + q))
    for j in range(F.shape[0]):
        f = np.zeros((n, n))
        f[:3, :3] = np.triu(F[j, :3, :3])
        np.fill_diagonal(f[:3, :3], 1.0)
        f[3, 3:ir], f[ir, ir:] = F[j, 3, 3:ir], F[j, ir, ir:]
        for a in (*range(4, ir), *range(ir + 1, n)):
            f[a, a - 1] = 1.0
        qq = np.zeros((n, n))
        qq[:3, :3], qq[3, 3], qq[ir, ir] = Q[j, :3, :3], Q[j, 3, 3], Q[j, ir, ir]
        kk = np.zeros(n)
        kk[ir] = kap[j, ir]
        if not (np.array_equal(f, F[j]) and np.array_equal(qq, Q[j]) and np.array_equal(kk, kap[j])):
            raise ValueError(f"set {j}: F, Q or kappa is not of the [dynamics, AR(p) companion, AR(q) companion] form")
        co[j, C_F01], co[j, C_F02], co[j, C_F12] = F[j, 0, 1], F[j, 0, 2], F[j, 1, 2]
        co[j, C_QD : C_QD + 9] = Q[j, :3, :3].ravel()
        co[j, C_QT], co[j, C_QR], co[j, C_KAP] = Q[j, 3, 3], Q[j, ir, ir], kap[j, ir]
        co[j, C_AR : C_AR + p], co[j, C_AR + p :] = F[j, 3, 3:ir], F[j, ir, ir:]
    return co


@njit(cache=True)
def ar_predict(x, P, xn, Pn, G, co, p, q):
    """``xn = F x + kappa``, ``Pn = F P F^T + Q`` on lanes, F = blkdiag(F_d, companion(beta), companion(gamma)).

    ``co`` (C_AR + p + q, LANES): each lane's coefficients (:func:`ar_coefficients`);
    ``G`` (4, n, LANES): work array; ``xn``/``Pn`` must not be ``x``/``P`` (swap them after).

    Structure: rows 2, 4..ir-1 and ir+1..n-1 of F select one row of what they
    multiply, so only rows 0, 1, 3 and ir of ``F P`` (``G``) and columns 0, 1,
    2, 3 and ir of ``(F P) F^T`` take arithmetic; the lag shifts are copies.
    Each entry is the sum :func:`predict` forms, over the same non-zeros in the
    same order (``Q`` first on the right product, ``kappa`` or 0 first for x),
    with the unit entries of F taken exactly (``1 v = v``).  So x is
    :func:`predict`'s bit for bit and P too, up to the sign of exact zeros: an
    exact-zero AR coefficient (the padding of a lower order) adds an exact +-0
    instead of being skipped, and a shifted zero is not renormalised to +0 (no
    operation downstream of P distinguishes -0 from +0, and x never gets a -0).
    Flop count: :func:`ar_predict_flops`.
    """
    L = LANES
    n = 3 + p + q
    ir = 3 + p
    b0 = C_AR  # beta_1
    g0 = C_AR + p  # gamma_1
    if (p < 1 or q < 1 or x.shape != (n, L) or xn.shape != (n, L) or P.shape != (n, n, L) or Pn.shape != (n, n, L)
            or G.shape != (4, n, L) or co.shape != (C_AR + p + q, L)):
        raise ValueError("ar_predict: arrays must be x, xn (n, LANES), P, Pn (n, n, LANES), G (4, n, LANES), co (C_AR + p + q, LANES)")
    f01 = lane_load(co, C_F01 * L)
    f02 = lane_load(co, C_F02 * L)
    f12 = lane_load(co, C_F12 * L)
    # G = rows 0, 1, 3 and ir of F P
    for c in range(n):
        p0 = lane_load(P, c * L)
        p1 = lane_load(P, (n + c) * L)
        p2 = lane_load(P, (2 * n + c) * L)
        lane_store(G, c * L, (p0 + f01 * p1) + f02 * p2)
        lane_store(G, (n + c) * L, p1 + f12 * p2)
        acc = lane_load(co, b0 * L) * lane_load(P, (3 * n + c) * L)
        for j in range(1, p):
            acc = acc + lane_load(co, (b0 + j) * L) * lane_load(P, ((3 + j) * n + c) * L)
        lane_store(G, (2 * n + c) * L, acc)
        acc = lane_load(co, g0 * L) * lane_load(P, (ir * n + c) * L)
        for j in range(1, q):
            acc = acc + lane_load(co, (g0 + j) * L) * lane_load(P, ((ir + j) * n + c) * L)
        lane_store(G, (3 * n + c) * L, acc)
    # Pn = (F P) F^T + Q row by row; row a of F P is a row of G or, for a selection row, of P
    for a in range(n):
        if a == 0 or a == 1:
            R, r = G, a
        elif a == 3:
            R, r = G, 2
        elif a == ir:
            R, r = G, 3
        elif a == 2:
            R, r = P, 2
        else:
            R, r = P, a - 1
        o = r * n * L  # row r of R
        w = a * n * L  # row a of Pn
        r0 = lane_load(R, o)
        r1 = lane_load(R, o + L)
        r2 = lane_load(R, o + 2 * L)
        if a < 3:
            qa = (C_QD + 3 * a) * L
            lane_store(Pn, w, ((lane_load(co, qa) + r0) + f01 * r1) + f02 * r2)
            lane_store(Pn, w + L, (lane_load(co, qa + L) + r1) + f12 * r2)
            lane_store(Pn, w + 2 * L, lane_load(co, qa + 2 * L) + r2)
        else:
            lane_store(Pn, w, (r0 + f01 * r1) + f02 * r2)
            lane_store(Pn, w + L, r1 + f12 * r2)
            lane_store(Pn, w + 2 * L, r2)
        acc = lane_load(co, b0 * L) * lane_load(R, o + 3 * L)
        if a == 3:
            acc = lane_load(co, C_QT * L) + acc
        for j in range(1, p):
            acc = acc + lane_load(co, (b0 + j) * L) * lane_load(R, o + (3 + j) * L)
        lane_store(Pn, w + 3 * L, acc)
        for b in range(4, ir):
            lane_store(Pn, w + b * L, lane_load(R, o + (b - 1) * L))
        acc = lane_load(co, g0 * L) * lane_load(R, o + ir * L)
        if a == ir:
            acc = lane_load(co, C_QR * L) + acc
        for j in range(1, q):
            acc = acc + lane_load(co, (g0 + j) * L) * lane_load(R, o + (ir + j) * L)
        lane_store(Pn, w + ir * L, acc)
        for b in range(ir + 1, n):
            lane_store(Pn, w + b * L, lane_load(R, o + (b - 1) * L))
    # x; every row of predict's x starts from kappa (0 off the rho_s,k row): kept, so x never holds a -0
    zero = lane_splat(0.0)
    x1 = lane_load(x, L)
    x2 = lane_load(x, 2 * L)
    lane_store(xn, 0, ((zero + lane_load(x, 0)) + f01 * x1) + f02 * x2)
    lane_store(xn, L, (zero + x1) + f12 * x2)
    lane_store(xn, 2 * L, zero + x2)
    acc = zero + lane_load(co, b0 * L) * lane_load(x, 3 * L)
    for j in range(1, p):
        acc = acc + lane_load(co, (b0 + j) * L) * lane_load(x, (3 + j) * L)
    lane_store(xn, 3 * L, acc)
    acc = lane_load(co, C_KAP * L) + lane_load(co, g0 * L) * lane_load(x, ir * L)
    for j in range(1, q):
        acc = acc + lane_load(co, (g0 + j) * L) * lane_load(x, (ir + j) * L)
    lane_store(xn, ir * L, acc)
    for a in range(4, ir):
        lane_store(xn, a * L, zero + lane_load(x, (a - 1) * L))
    for a in range(ir + 1, n):
        lane_store(xn, a * L, zero + lane_load(x, (a - 1) * L))


def ar_predict_flops(p: int, q: int) -> int:
    """Floating-point additions and multiplications of one :func:`ar_predict` per trial, counted from its code."""
    n = 3 + p + q
    g = n * (4 + 2 + (2 * p - 1) + (2 * q - 1))  # rows 0, 1, 3, ir of F P, per column
    pn = 3 * (5 + 3 + 1) + (n - 3) * (4 + 2)  # columns 0-2 (with Q_d on rows 0-2)
    pn += n * ((2 * p - 1) + (2 * q - 1)) + 2  # columns 3 and ir (+ Q[3, 3], Q[ir, ir])
    xs = 5 + 3 + 1 + 2 * p + 2 * q + (p - 1) + (q - 1)  # x, every row from kappa or 0
    return g + pn + xs


@njit(cache=True)
def iq_update(x, P, ph0, ph1, A, ir, r, yr, yi):
    """EKF update on z = [I, Q] (eqs. 13-14), R = r I_2, on lanes.

    H has non-zero entries only in the columns of theta_d (0), theta_s,k (3)
    and rho_s,k (``ir``), so ``P H^T`` (``ph0``, ``ph1``) is two weighted
    column sums and the 2 x 2 innovation covariance is inverted in closed form;
    ``x += K e``, ``P -= K (P H^T)^T`` (every entry, as the one-trial form had it).
    ``x`` (n, LANES), ``P`` (n, n, LANES), ``r``/``yr``/``yi`` (LANES,);
    work arrays ``ph0``, ``ph1`` (n, LANES).  A zero innovation determinant on
    any lane raises ZeroDivisionError (:func:`lanes_any_zero`), as the scalar division did.
    """
    L = LANES
    n = x.shape[0]
    if (not 3 < ir < n or x.shape != (n, L) or P.shape != (n, n, L) or ph0.shape != (n, L) or ph1.shape != (n, L)
            or r.shape != (L,) or yr.shape != (L,) or yi.shape != (L,)):
        raise ValueError("iq_update: arrays must be x, ph0, ph1 (n, LANES), P (n, n, LANES), r, yr, yi (LANES,), 3 < ir < n")
    # the linearisation point theta_d + theta_s (trig.sincos on the lane vector)
    rho = lane_load(x, ir * L)
    s_, c_ = trig.sincos(lane_load(x, 0) + lane_load(x, 3 * L))
    a0 = -A * rho * s_
    a1 = A * rho * c_
    b0 = A * c_
    b1 = A * s_
    e0 = lane_load(yr, 0) - A * rho * c_
    e1 = lane_load(yi, 0) - A * rho * s_
    for a in range(n):
        o = a * n * L
        u = lane_load(P, o) + lane_load(P, o + 3 * L)
        v = lane_load(P, o + ir * L)
        lane_store(ph0, a * L, a0 * u + b0 * v)
        lane_store(ph1, a * L, a1 * u + b1 * v)
    hu0 = lane_load(ph0, 0) + lane_load(ph0, 3 * L)
    hu1 = lane_load(ph1, 0) + lane_load(ph1, 3 * L)
    rr = lane_load(r, 0)
    s00 = a0 * hu0 + b0 * lane_load(ph0, ir * L) + rr
    s01 = a0 * hu1 + b0 * lane_load(ph1, ir * L)
    s11 = a1 * hu1 + b1 * lane_load(ph1, ir * L) + rr
    det = s00 * s11 - s01 * s01
    if lanes_any_zero(det):
        raise ZeroDivisionError("division by zero")
    i00 = s11 / det
    i01 = -s01 / det
    i11 = s00 / det
    for a in range(n):
        h0 = lane_load(ph0, a * L)
        h1 = lane_load(ph1, a * L)
        k0 = h0 * i00 + h1 * i01
        k1 = h0 * i01 + h1 * i11
        lane_store(x, a * L, lane_load(x, a * L) + (k0 * e0 + k1 * e1))
        o = a * n * L
        for b in range(n):
            lane_store(P, o + b * L, lane_load(P, o + b * L) - (k0 * lane_load(ph0, b * L) + k1 * lane_load(ph1, b * L)))


def iq_update_flops(n: int) -> int:
    """Floating-point operations of one :func:`iq_update` per trial, counted from its code (3 of them
    divisions), :func:`.trig.sincos` included (:data:`.trig.SINCOS_OPS`)."""
    point = 1 + trig.SINCOS_OPS + 3 + 2 + 1 + 1 + 3 + 3  # th, sin and cos, a0 (with -A), a1, b0, b1, e0, e1
    ph = 7 * n  # u, P H^T (two columns)
    s = 2 + 4 + 3 + 4 + 3 + 4  # hu0, hu1, s00, s01, s11, det, S^-1 (3 divisions, one negation)
    gain = 10 * n  # K (two columns) and x += K e
    cov = 4 * n * n  # P -= K (P H^T)^T, every entry
    return point + ph + s + gain + cov


@njit(cache=True)
def nearest_index_lanes(value, points):
    """:func:`nearest_index` on every lane of ``value`` (Lanes): the index, as a float, of the nearest point (the first one on ties)."""
    best = lane_splat(0.0)
    best_d = abs(value - points[0])
    for j in range(1, points.size):
        d = abs(value - points[j])
        best = lane_where_less(d, best_d, j, best)
        best_d = lane_where_less(d, best_d, d, best_d)
    return best


@njit(cache=True)
def window_push_lanes(b1, b2, pos, s1, s2, count, v1, v2):
    """:func:`window_push` on LANES ring buffers at once; returns (pos, count), updates ``s1``, ``s2`` in place.

    ``b1``, ``b2`` (window, LANES): one ring buffer per lane (column); ``s1``,
    ``s2`` (LANES,) their running sums; ``v1``, ``v2`` (LANES,) the values
    pushed.  Per lane the arithmetic of :func:`window_push`: ``s += v - b[pos]``
    and, once per lap, the exact re-sum in index order from 0 (as
    ``ndarray.sum`` in numba).
    """
    L = LANES
    w = b1.shape[0]
    if b1.shape != (w, L) or b2.shape != (w, L) or s1.shape != (L,) or s2.shape != (L,) or v1.shape != (L,) or v2.shape != (L,) or not 0 <= pos < w:
        raise ValueError("window_push_lanes: buffers (window, LANES), sums and values (LANES,), 0 <= pos < window")
    o = pos * L
    a1 = lane_load(v1, 0)
    a2 = lane_load(v2, 0)
    lane_store(s1, 0, lane_load(s1, 0) + (a1 - lane_load(b1, o)))
    lane_store(s2, 0, lane_load(s2, 0) + (a2 - lane_load(b2, o)))
    lane_store(b1, o, a1)
    lane_store(b2, o, a2)
    pos = (pos + 1) % w
    count = min(count + 1, w)
    if pos == 0:
        t1 = lane_splat(0.0)
        t2 = lane_splat(0.0)
        for j in range(w):
            t1 = t1 + lane_load(b1, j * L)
            t2 = t2 + lane_load(b2, j * L)
        lane_store(s1, 0, t1)
        lane_store(s2, 0, t2)
    return pos, count


# --- lanes: the discriminator KFs (kf, akf, akf_ar; Susi's AKF / SAKF PLL) ------------------
#
# The one-trial blocks above (predict, scalar_update, weighted_scalar_update, the
# discriminators, window_push + m2m4_split) on LANES trials at once, for kernels that run
# trials in blocks like the AEKF-AR.  Per lane every operation is the scalar block's, in
# the same order and with the same operands (the zero entries of H and the unit entries
# of F included: an inf or NaN meets them as it did), so each lane gets the bits of the
# scalar call, the sine, cosine and arctangents (:mod:`.trig`) included.


@njit(cache=True)
def sparse_predict_lanes(x, P, xn, FP, Q, rows, cols, vals, count):
    """:func:`predict` without kappa on lanes: ``x <- F x``, ``P <- F P F^T + Q``, F given by its non-zeros.

    ``x`` (n, LANES) and ``P`` (n, n, LANES) are updated in place; ``Q``
    (n, n, LANES): each lane's process noise; ``rows``, ``cols``, ``vals``,
    ``count``: the non-zeros of F (:func:`nonzeros`, one set, common to the
    lanes); work arrays ``xn`` (n, LANES), ``FP`` (n, n, LANES).  Per lane the
    sums of :func:`predict` (``use_kap`` False): each x entry from 0.0, F P from
    0.0, P from Q, accumulated over the same non-zeros in the same order (unit
    entries of F multiplied, as there), so x and P are the scalar block's bit for bit.
    """
    L = LANES
    n = x.shape[0]
    if x.shape != (n, L) or xn.shape != (n, L) or P.shape != (n, n, L) or FP.shape != (n, n, L) or Q.shape != (n, n, L):
        raise ValueError("sparse_predict_lanes: arrays must be x, xn (n, LANES), P, FP, Q (n, n, LANES)")
    zero = lane_splat(0.0)
    for a in range(n):
        lane_store(xn, a * L, zero)
    for e in range(n * n):
        lane_store(FP, e * L, zero)
    for m in range(count):
        a, c, v = rows[m], cols[m], vals[m]
        lane_store(xn, a * L, lane_load(xn, a * L) + v * lane_load(x, c * L))
        for b in range(n):
            o = (a * n + b) * L
            lane_store(FP, o, lane_load(FP, o) + v * lane_load(P, (c * n + b) * L))
    for a in range(n):
        lane_store(x, a * L, lane_load(xn, a * L))
    for e in range(n * n):
        lane_store(P, e * L, lane_load(Q, e * L))
    for m in range(count):
        b, c, v = rows[m], cols[m], vals[m]
        for a in range(n):
            o = (a * n + b) * L
            lane_store(P, o, lane_load(P, o) + v * lane_load(FP, (a * n + c) * L))


@njit(cache=True)
def innovation_terms_lanes(P, H, R, PH):
    """:func:`innovation_terms` on lanes: ``PH = P H^T`` (n, LANES) written, ``S = H P H^T + R`` returned (Lanes).

    ``P`` (n, n, LANES), ``H`` (n,) common to the lanes, ``R`` (LANES,)."""
    L = LANES
    n = PH.shape[0]
    if P.shape != (n, n, L) or PH.shape != (n, L) or H.shape != (n,) or R.shape != (L,):
        raise ValueError("innovation_terms_lanes: arrays must be P (n, n, LANES), H (n,), R (LANES,), PH (n, LANES)")
    S = lane_load(R, 0)
    for a in range(n):
        acc = lane_splat(0.0)
        for b in range(n):
            acc = acc + lane_load(P, (a * n + b) * L) * H[b]
        lane_store(PH, a * L, acc)
        S = S + H[a] * acc
    return S


@njit(cache=True)
def scalar_update_lanes(x, P, PH, H, R, nu):
    """:func:`scalar_update` on lanes: S = H P H^T + R, K = P H^T / S, x += K nu, P -= K (P H^T)^T.

    ``x`` (n, LANES), ``P`` (n, n, LANES) in place; ``H`` (n,) common; ``R``,
    ``nu`` (LANES,); work array ``PH`` (n, LANES).  An exact-zero S on any lane
    raises ZeroDivisionError, as the scalar division does."""
    L = LANES
    n = x.shape[0]
    if x.shape != (n, L) or nu.shape != (L,):
        raise ValueError("scalar_update_lanes: arrays must be x (n, LANES), nu (LANES,)")
    S = innovation_terms_lanes(P, H, R, PH)
    if lanes_any_zero(S):
        raise ZeroDivisionError("division by zero")
    e = lane_load(nu, 0)
    for a in range(n):
        lane_store(x, a * L, lane_load(x, a * L) + lane_load(PH, a * L) / S * e)
    for a in range(n):
        ka = lane_load(PH, a * L) / S
        o = a * n * L
        for b in range(n):
            lane_store(P, o + b * L, lane_load(P, o + b * L) - ka * lane_load(PH, b * L))


@njit(cache=True)
def weighted_scalar_update_lanes(x, P, PH, H, R, nu, w):
    """:func:`weighted_scalar_update` on lanes (gain weighted by ``w``, Joseph covariance); ``w`` (LANES,),
    otherwise the arrays of :func:`scalar_update_lanes`.  An exact-zero S on any lane raises ZeroDivisionError."""
    L = LANES
    n = x.shape[0]
    if x.shape != (n, L) or nu.shape != (L,) or w.shape != (L,):
        raise ValueError("weighted_scalar_update_lanes: arrays must be x (n, LANES), nu, w (LANES,)")
    S = innovation_terms_lanes(P, H, R, PH)
    if lanes_any_zero(S):
        raise ZeroDivisionError("division by zero")
    wv = lane_load(w, 0)
    g = (2.0 * wv - wv * wv) / S
    e = lane_load(nu, 0)
    for a in range(n):
        lane_store(x, a * L, lane_load(x, a * L) + wv * lane_load(PH, a * L) / S * e)
    for a in range(n):
        o = a * n * L
        gpa = g * lane_load(PH, a * L)
        for b in range(n):
            lane_store(P, o + b * L, lane_load(P, o + b * L) - gpa * lane_load(PH, b * L))


@njit(cache=True)
def atan2_discriminator_lanes(yr, yi, phase, out):
    """``out[ln] = atan2_discriminator(yr[ln], yi[ln], phase[ln])`` on every lane (one SIMD evaluation); arrays (LANES,)."""
    L = LANES
    if yr.shape != (L,) or yi.shape != (L,) or phase.shape != (L,) or out.shape != (L,):
        raise ValueError("atan2_discriminator_lanes: arrays must be (LANES,)")
    lane_store(out, 0, atan2_discriminator(lane_load(yr, 0), lane_load(yi, 0), lane_load(phase, 0)))


@njit(cache=True)
def atan_discriminator_lanes(yr, yi, phase, out):
    """``out[ln] = atan_discriminator(yr[ln], yi[ln], phase[ln])`` on every lane (one SIMD evaluation); arrays (LANES,)."""
    L = LANES
    if yr.shape != (L,) or yi.shape != (L,) or phase.shape != (L,) or out.shape != (L,):
        raise ValueError("atan_discriminator_lanes: arrays must be (LANES,)")
    lane_store(out, 0, atan_discriminator(lane_load(yr, 0), lane_load(yi, 0), lane_load(phase, 0)))


@njit(cache=True)
def lane_trials(c0, n_tr, trial):
    """The trial of every lane of the block of ``LANES`` trials starting at trial ``c0``, into ``trial`` (LANES,) int64.

    A short last block repeats its last trial in the lanes past it (computed,
    never written out); returns how many lanes are real trials.
    """
    for ln in range(LANES):
        trial[ln] = min(c0 + ln, n_tr - 1)
    return min(LANES, n_tr - c0)


@njit(cache=True)
def prompt_discriminator_lanes(y, trial, i, phase, costas, yr, yi, out):
    """Epoch ``i`` of every lane's trial, ``y[trial[ln], i]``, into ``yr``/``yi`` (LANES,) and its discriminator
    against ``phase`` into ``out``: :func:`atan_discriminator` (Costas, ``costas``) or :func:`atan2_discriminator`."""
    for ln in range(LANES):
        v = y[trial[ln], i]
        yr[ln], yi[ln] = v.real, v.imag
    if costas:
        atan_discriminator_lanes(yr, yi, phase, out)
    else:
        atan2_discriminator_lanes(yr, yi, phase, out)


@njit(cache=True)
def m2m4_lanes(b2, b4, pos, s2, s4, count, yr, yi, p2, p4, min_epochs, prior_signal, prior_noise, floor_fraction, sig, noi):
    """The M2M4 window of the discriminator KFs on lanes; returns (pos, count).

    Pushes ``p2 = yr^2 + yi^2`` (LANES,: each lane's prompt power ``|P|^2``) and
    ``p4 = p2 * p2`` (both written; scratch) into the ring buffers ``b2``, ``b4`` (window, LANES) with running sums ``s2``,
    ``s4`` (LANES,) (:func:`window_push_lanes`), then writes ``sig``, ``noi``
    (LANES,): the priors while ``count < min_epochs``, else :func:`m2m4_split`
    of the window means -- per lane the scalar kernels' ``window_push`` and split.
    """
    L = LANES
    if yr.shape != (L,) or yi.shape != (L,) or p2.shape != (L,) or p4.shape != (L,) or sig.shape != (L,) or noi.shape != (L,):
        raise ValueError("m2m4_lanes: yr, yi, p2, p4, sig, noi must be (LANES,)")
    vr, vi = lane_load(yr, 0), lane_load(yi, 0)
    lane_store(p2, 0, vr * vr + vi * vi)
    v = lane_load(p2, 0)
    lane_store(p4, 0, v * v)
    pos, count = window_push_lanes(b2, b4, pos, s2, s4, count, p2, p4)
    if count < min_epochs:
        lane_store(sig, 0, lane_splat(prior_signal))
        lane_store(noi, 0, lane_splat(prior_noise))
    else:
        sg, nz = m2m4_split(lane_load(s2, 0) / count, lane_load(s4, 0) / count, floor_fraction)
        lane_store(sig, 0, sg)
        lane_store(noi, 0, nz)
    return pos, count
