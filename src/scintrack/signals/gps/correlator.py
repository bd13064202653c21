"""Early/prompt/late correlator outputs of a GPS L1 C/A receiver at 1 ms (closed loop).

Signal model for the jammed GPS dataset (Zhao et al., measurement model eqs.
6-9, extended to E/P/L and to the residual code, phase and frequency errors of
a tracking loop).  For correlator X in (E, P, L) over one integration of
length T:

``I_X = a d R(dtau + o_X) sinc(pi df T) cos(phibar) + sigma n_IX``
``Q_X = a d R(dtau + o_X) sinc(pi df T) sin(phibar) + sigma n_QX``

* ``R(x) = max(0, 1 - |x|)``: the C/A autocorrelation triangle (infinite
  bandwidth; the 1/1023 off-peak level of the Gold code is neglected);
* ``dtau`` = true code delay minus replica code delay in chips (the error at
  mid-interval; code Doppler within 1 ms, < 0.01 chip, is neglected);
  ``o_E = +spacing/2``, ``o_P = 0``, ``o_L = -spacing/2``, so a replica that is
  early (``dtau > 0``) gives ``L > E``;
* ``dphi`` = true minus replica carrier phase (rad) at the start of the
  interval and ``df`` = true minus replica frequency (Hz); averaging
  ``exp(j(dphi + 2 pi df t))`` over [0, T] gives the factor
  ``sinc(pi df T) exp(j phibar)`` with ``phibar = dphi + pi df T`` the mean
  phase error over the interval, ``sinc(x) = sin(x)/x``;
* ``d = +-1``: the navigation data bit (constant within one 1 ms code period
  when the epochs are aligned with the code, as here).

Normalisation (:func:`gains`).  ``'agc'`` (default): the noise has unit
variance per component and ``a = sqrt(2 (C/N0) T)`` (:func:`amplitude`), so
``a^2 / (2 sigma^2) = C/N0 T``: eq. (9)'s unit amplitude with
``sigma_v^2 = 1 / (2 T C/N0)``, rescaled to unit noise; a jammer lowers ``a``.  ``'fixed'``: a fixed-gain front end normalised to the
unjammed noise density N0_ref: ``a = sqrt(2 (C/N0_ref) T)`` stays fixed and
``sigma = sqrt(N0_eff / N0_ref) = 10^((cn0_ref - cn0) / 20)`` grows with the
effective noise density.  Both give the same SNR at every epoch.

Noise (:class:`NoiseStream`).  Within I (and within Q) the E/P/L noises are
correlated as ``Sigma_ab = R(o_a - o_b)`` (white noise through the same code
replica at different lags); I and Q are independent.  They are drawn as
``L z`` with ``L`` the Cholesky factor of Sigma.  Each (trial, sv) has its
own stream cut into fixed blocks of ``block`` epochs; block k of (trial, sv)
is drawn from its own ``SeedSequence(seed, spawn_key=(stable_key(name),
trial, sv, k))`` (the grandchild (sv, k) of
``scintrack.seeding.seed_sequence(seed, name, trial)``), so the noise of an
epoch is a function of (seed, name, trial, sv, epoch) only: independent of the
tracker, of the order in which blocks are requested and of how trials are
batched.  The stream stores unit-variance noise; ``sigma`` scales it.

Speed.  :func:`epl` is a numba ``@njit`` scalar kernel to be called inside
compiled tracking loops; :func:`correlate` is the same model written with
numpy broadcasting (tests check they agree to 1e-12).
``benchmarks/bench_gps_correlator.py`` measures both and the noise draws.

Column order of every ``(..., 6)`` array: :data:`CHANNELS` =
``(IE, IP, IL, QE, QP, QL)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numba import njit

from ...seeding import stable_key

CHANNELS = ("IE", "IP", "IL", "QE", "QP", "QL")
GAIN_MODES = ("agc", "fixed")


def offsets(spacing_chips: float) -> np.ndarray:
    """Lag offsets ``(o_E, o_P, o_L) = (+spacing/2, 0, -spacing/2)`` in chips."""
    s = _spacing(spacing_chips)
    return np.array([0.5 * s, 0.0, -0.5 * s])


def triangle(x):
    """C/A autocorrelation ``R(x) = max(0, 1 - |x|)`` (x in chips)."""
    return np.maximum(0.0, 1.0 - np.abs(x))


def noise_covariance(spacing_chips: float) -> np.ndarray:
    """3x3 covariance of the (E, P, L) noise within I (or Q): ``R(o_a - o_b)``."""
    o = offsets(spacing_chips)
    return triangle(o[:, None] - o[None, :])


def amplitude(cn0_dbhz, T: float):
    """AGC-normalised signal amplitude ``sqrt(2 (C/N0) T)`` (unit noise per component)."""
    return np.sqrt(2.0 * 10.0 ** (np.asarray(cn0_dbhz, dtype=float) / 10.0) * _positive(T, "T"))


def gains(cn0_dbhz, T: float, mode: str = "agc", cn0_ref_dbhz=None):
    """``(a, sigma)`` of the ``'agc'`` or ``'fixed'`` normalisation (module docstring)."""
    if mode == "agc":
        a = amplitude(cn0_dbhz, T)
        return a, np.ones_like(a)
    if mode == "fixed":
        if cn0_ref_dbhz is None:
            raise ValueError("gain mode 'fixed' needs cn0_ref_dbhz (the C/N0 of the unjammed front end)")
        a = amplitude(cn0_ref_dbhz, T)
        sigma = 10.0 ** ((np.asarray(cn0_ref_dbhz, dtype=float) - np.asarray(cn0_dbhz, dtype=float)) / 20.0)
        return np.broadcast_to(a, np.broadcast(a, sigma).shape).copy(), sigma
    raise ValueError(f"gain mode must be one of {GAIN_MODES} (got {mode!r})")


def _positive(value: float, arg: str) -> float:
    value = float(value)
    if not (np.isfinite(value) and value > 0.0):
        raise ValueError(f"{arg} must be a finite number > 0 (got {value!r})")
    return value


def _spacing(spacing_chips: float) -> float:
    s = _positive(spacing_chips, "spacing_chips")
    if s > 2.0:
        raise ValueError(f"spacing_chips is the early-late spacing in chips, 0 < spacing <= 2 (got {s})")
    return s


# --- the compiled scalar model ---------------------------------------------------


@njit(cache=True)
def _tri(x):
    return max(0.0, 1.0 - abs(x))


@njit(cache=True)
def epl(a, d, dtau, dphi, df, T, spacing, noise6, out6, sigma=1.0):
    """Write ``(IE, IP, IL, QE, QP, QL)`` of one epoch into ``out6`` (numba; see module docstring).

    ``noise6`` is unit-variance correlated noise (a row of :class:`NoiseStream`),
    scaled here by ``sigma``.
    """
    x = math.pi * df * T
    loss = 1.0 if x == 0.0 else math.sin(x) / x
    phibar = dphi + x
    amp = a * d * loss
    ci = amp * math.cos(phibar)
    cq = amp * math.sin(phibar)
    h = 0.5 * spacing
    re, rp, rl = _tri(dtau + h), _tri(dtau), _tri(dtau - h)
    out6[0] = ci * re + sigma * noise6[0]
    out6[1] = ci * rp + sigma * noise6[1]
    out6[2] = ci * rl + sigma * noise6[2]
    out6[3] = cq * re + sigma * noise6[3]
    out6[4] = cq * rp + sigma * noise6[4]
    out6[5] = cq * rl + sigma * noise6[5]


# --- the numpy model ------------------------------------------------------------------


def correlate(a, d, dtau, dphi, df, T: float, spacing: float, noise=None, sigma=1.0) -> np.ndarray:
    """E/P/L outputs ``(..., 6)`` broadcast over the leading shapes of all arguments.

    ``noise`` has shape ``(..., 6)`` (unit variance; ``None`` gives the
    noise-free outputs) and is scaled by ``sigma``.
    """
    T = _positive(T, "T")
    o = offsets(spacing)
    a, d, dtau, dphi, df, sigma = (np.asarray(v, dtype=float) for v in (a, d, dtau, dphi, df, sigma))
    x = np.pi * df * T
    amp = a * d * np.sinc(df * T)
    phibar = dphi + x
    r = triangle(dtau[..., None] + o)
    out = np.concatenate([(amp * np.cos(phibar))[..., None] * r, (amp * np.sin(phibar))[..., None] * r], axis=-1)
    if noise is not None:
        noise = np.asarray(noise, dtype=float)
        if noise.shape[-1:] != (6,):
            raise ValueError(f"noise must have shape (..., 6) in the order {CHANNELS} (got {noise.shape})")
        out = out + sigma[..., None] * noise
    return out


# --- the noise stream ---------------------------------------------------------------


@njit(cache=True)
def _mix(z, chol, out):
    """``out[i] = (L z[i, :3], L z[i, 3:])`` for a lower-triangular 3x3 ``L``."""
    for i in range(z.shape[0]):
        for g in (0, 3):
            z0, z1, z2 = z[i, g], z[i, g + 1], z[i, g + 2]
            out[i, g] = chol[0, 0] * z0
            out[i, g + 1] = chol[1, 0] * z0 + chol[1, 1] * z1
            out[i, g + 2] = chol[2, 0] * z0 + chol[2, 1] * z1 + chol[2, 2] * z2


class NoiseStream:
    """Correlated unit-variance E/P/L noise, random access by (trial, sv, block).

    ``block(trial, sv, k)`` returns epochs ``[k*block, (k+1)*block)`` as
    ``(block, 6)``; ``epochs(trials, sv, k0, k1)`` any epoch range for several
    trials as ``(len(trials), k1 - k0, 6)``.  Both give bit-identical values
    for the same epoch.
    """

    def __init__(self, seed: int, name: str, spacing_chips: float, block: int = 1000):
        if int(seed) != seed or seed < 0:
            raise ValueError(f"seed must be an integer >= 0 (got {seed!r})")
        if not name:
            raise ValueError("name must be a non-empty stream name (e.g. the dataset name)")
        if int(block) != block or block < 1:
            raise ValueError(f"block must be an integer >= 1 epochs (got {block!r})")
        self.seed, self.name, self.block_size = int(seed), str(name), int(block)
        self.spacing = _spacing(spacing_chips)
        self.cholesky = np.linalg.cholesky(noise_covariance(self.spacing))
        self._key = stable_key(self.name)

    def seed_sequence(self, trial: int, sv: int, k: int) -> np.random.SeedSequence:
        """The SeedSequence of block ``k`` of (``trial``, ``sv``)."""
        for arg, v in (("trial", trial), ("sv", sv), ("block index k", k)):
            if int(v) != v or v < 0:
                raise ValueError(f"{arg} must be an integer >= 0 (got {v!r})")
        return np.random.SeedSequence(self.seed, spawn_key=(self._key, int(trial), int(sv), int(k)))

    def _white(self, trial: int, sv: int, k: int, out: np.ndarray) -> None:
        rng = np.random.Generator(np.random.PCG64(self.seed_sequence(trial, sv, k)))
        rng.standard_normal(out=out)

    def block(self, trial: int, sv: int, k: int) -> np.ndarray:
        """Noise of epochs ``[k*block, (k+1)*block)``, shape ``(block, 6)``."""
        z = np.empty((self.block_size, 6))
        self._white(trial, sv, k, z)
        out = np.empty_like(z)
        _mix(z, self.cholesky, out)
        return out

    def epochs(self, trials: Sequence[int] | int, sv: int, k0: int, k1: int, out: np.ndarray | None = None) -> np.ndarray:
        """Noise of epochs ``[k0, k1)`` for each of ``trials``: ``(len(trials), k1 - k0, 6)``.

        ``out`` (that shape, float64, C-contiguous) is filled instead of a new array.
        """
        trials = [trials] if np.isscalar(trials) else list(trials)
        if int(k0) != k0 or int(k1) != k1 or not 0 <= k0 <= k1:
            raise ValueError(f"epoch range must satisfy 0 <= k0 <= k1 (got k0={k0!r}, k1={k1!r})")
        shape = (len(trials), k1 - k0, 6)
        if out is None:
            out = np.empty(shape)
        elif out.shape != shape or out.dtype != np.float64 or not out.flags.c_contiguous:
            raise ValueError(f"out must be a C-contiguous float64 array of shape {shape} (got {out.shape}, {out.dtype})")
        b = self.block_size
        z = np.empty((b, 6))
        for row, trial in enumerate(trials):
            for k in range(k0 // b, -(-k1 // b)):
                lo, hi = max(k0, k * b), min(k1, (k + 1) * b)
                self._white(trial, sv, k, z)
                _mix(z[lo - k * b : hi - k * b], self.cholesky, out[row, lo - k0 : hi - k0])
        return out


def open_loop(
    stream: NoiseStream,
    trials: Sequence[int],
    sv: int,
    k0: int,
    cn0_dbhz,
    bits,
    T: float,
    *,
    code_offset_chips=0.0,
    phase_offset_rad=0.0,
    freq_offset_hz=0.0,
    gain: str = "agc",
    cn0_ref_dbhz=None,
) -> np.ndarray:
    """E/P/L ``(len(trials), n, 6)`` for epochs ``k0 .. k0+n-1`` with replica = truth + offsets.

    ``bits`` (d = +-1) has shape ``(n,)`` or ``(trials, n)``; ``cn0_dbhz`` and
    the offsets (replica minus truth: chips, rad at the start of each
    interval, Hz) broadcast to ``(trials, n)``.  The errors fed to the model
    are truth minus replica, i.e. minus the offsets.  Noise comes from
    ``stream`` (its spacing is used).
    """
    bits = np.asarray(bits, dtype=float)
    if bits.ndim not in (1, 2) or not np.all(np.abs(bits) == 1.0):
        raise ValueError("bits must be a (n,) or (trials, n) array of +-1 data bits")
    n = bits.shape[-1]
    noise = stream.epochs(trials, sv, k0, k0 + n)
    a, sigma = gains(cn0_dbhz, T, gain, cn0_ref_dbhz)
    return correlate(
        a, bits, -np.asarray(code_offset_chips, dtype=float), -np.asarray(phase_offset_rad, dtype=float),
        -np.asarray(freq_offset_hz, dtype=float), T, stream.spacing, noise, sigma,
    )
