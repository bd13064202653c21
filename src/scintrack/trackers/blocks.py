"""The numba building blocks every tracker kernel is made of (each formula once).

Vila-Valls et al. 2018 (Sec. IV-V) equations and the block that implements them:

* eq. (8), (11) prediction ``x <- F x (+ kappa)``, ``P <- F P F^T + Q`` with
  the block-diagonal F given by its non-zeros: :func:`predict` (and
  :func:`nonzeros` to list them);
* scalar measurement update (discriminator KFs, ``H = [1, 0, 0, (1, 0..)]``,
  Sec. V-A): :func:`scalar_update` (its ``P H^T`` and ``S``: :func:`innovation_terms`);
  with a weighted gain and the Joseph covariance (Susi 2014, eq. 12):
  :func:`weighted_scalar_update`; Susi's eq. (10) R: :func:`costas_variance`;
  the (phase, frequency) white-noise Q of Susi's eqs. (3)-(8): :func:`phase_frequency_q`;
* eqs. (13)-(14) I/Q (2 x 2) EKF update with the Jacobian of ``h(x) = A rho_s
  [cos(theta_d + theta_s), sin(theta_d + theta_s)]`` in closed form:
  :func:`iq_update`;
* ATAN2 discriminator ``atan2(Q, I)`` of the prompt against the replica phase:
  :func:`atan2_discriminator`; its data-insensitive (Costas) form ``atan(Q/I)``:
  :func:`atan_discriminator`;
* eq. (12) discriminator variance at ``x = 2 C/N0 Ts``: :func:`atan_variance`;
* M2M4 signal/noise split (GNSS-SDR ``cn0_m2m4_estimator``):
  :func:`m2m4_signal_power`, :func:`m2m4_split`; C/N0 from the powers:
  :func:`cn0_from_powers`;
* sliding-window running sums (ring buffers, exact re-sum once per lap):
  :func:`window_push`, window moments :func:`window_mean_var`;
* noise-corrected S4 from intensity moments (Sec. V-B): :func:`s4_corrected`;
* nearest adaptation point (Sec. V-B): :func:`nearest_index`;
* the mirror fold of the AEKF-AR (an isolating option, not in the paper):
  :func:`fold_mirror`; periodic symmetrisation of P: :func:`symmetrise`;
* third-order PLL loop filter (Kaplan & Hegarty): :func:`pll_constants`,
  :func:`pll_step`.

Every block is an ``@njit`` function: the kernels call them (numba inlines
them; the expressions are written exactly as in the original kernels so the
compiled arithmetic, hence every bit of the results, is unchanged; never turn
fastmath on here).  Plain Python can call them on scalars, and the
array-valued formulas used by the vectorised numpy estimators
(:mod:`scintrack.estimators`) are ``numba.vectorize`` ufuncs compiled from the
*same* Python function (``*_ufunc`` below), so no formula is written twice.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, vectorize

_F8_2 = ["float64(float64, float64)"]
_F8_3 = ["float64(float64, float64, float64)"]


class _Ufunc:
    """``numba.vectorize(signatures)(py)``, built on first call (keeps imports cheap)."""

    def __init__(self, py, signatures):
        self.py, self.signatures, self._ufunc = py, signatures, None
        self.__doc__ = f"Array (ufunc) form of :func:`{py.__name__.lstrip('_')}`."

    def __call__(self, *args):
        if self._ufunc is None:
            self._ufunc = vectorize(self.signatures, cache=True)(self.py)
        return self._ufunc(*args)


# --- eq. (12): discriminator variance ---------------------------------------


def _atan_variance(cn0_hz, ts):
    x = max(2.0 * cn0_hz * ts, 1e-6)
    return (math.exp(-0.8 * math.sqrt(x)) + 1.0) * math.erf(0.4 * x) / x


atan_variance = njit(cache=True)(_atan_variance)
atan_variance_ufunc = _Ufunc(_atan_variance, _F8_2)


# --- ATAN2 discriminator --------------------------------------------------------


def _atan2_discriminator(yr, yi, phase):
    c_, s_ = math.cos(phase), math.sin(phase)
    return math.atan2(yi * c_ - yr * s_, yr * c_ + yi * s_)


atan2_discriminator = njit(cache=True)(_atan2_discriminator)
atan2_discriminator_ufunc = _Ufunc(_atan2_discriminator, _F8_3)


def _atan_discriminator(yr, yi, phase):
    """Costas (two-quadrant) ``atan(Q/I)``: insensitive to the data bit, error in (-pi/2, pi/2]."""
    c_, s_ = math.cos(phase), math.sin(phase)
    i_ = yr * c_ + yi * s_
    q_ = yi * c_ - yr * s_
    if i_ == 0.0:
        return 0.5 * math.pi if q_ >= 0.0 else -0.5 * math.pi
    return math.atan(q_ / i_)


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


def _s4_corrected(mean_i, var_i, noise_power):
    sig = max(mean_i - noise_power, 1e-12)
    s4sq = (var_i - 2.0 * sig * noise_power - noise_power * noise_power) / (sig * sig)
    return math.sqrt(max(s4sq, 0.0))


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
def iq_update(x, P, ph0, ph1, A, ir, r, yr, yi):
    """EKF update on z = [I, Q] (eqs. 13-14), R = r I_2.

    H has non-zero entries only in the columns of theta_d (0), theta_s,k (3)
    and rho_s,k (``ir``), so ``P H^T`` is two weighted column sums and the
    2 x 2 innovation covariance is inverted in closed form.
    """
    n = x.size
    th = x[0] + x[3]
    rho = x[ir]
    c_, s_ = math.cos(th), math.sin(th)
    a0, a1 = -A * rho * s_, A * rho * c_
    b0, b1 = A * c_, A * s_
    for a in range(n):
        u = P[a, 0] + P[a, 3]
        v = P[a, ir]
        ph0[a] = a0 * u + b0 * v
        ph1[a] = a1 * u + b1 * v
    hu0 = ph0[0] + ph0[3]
    hu1 = ph1[0] + ph1[3]
    s00 = a0 * hu0 + b0 * ph0[ir] + r
    s01 = a0 * hu1 + b0 * ph1[ir]
    s11 = a1 * hu1 + b1 * ph1[ir] + r
    det = s00 * s11 - s01 * s01
    i00, i01, i11 = s11 / det, -s01 / det, s00 / det
    e0 = yr - A * rho * c_
    e1 = yi - A * rho * s_
    for a in range(n):
        k0 = ph0[a] * i00 + ph1[a] * i01
        k1 = ph0[a] * i01 + ph1[a] * i11
        x[a] += k0 * e0 + k1 * e1
        for b in range(n):
            P[a, b] -= k0 * ph0[b] + k1 * ph1[b]


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
