"""Carrier-aided noncoherent early-minus-late DLL, closed loop on the E/P/L correlator model.

The code tracking loop of the jammed GPS L1 C/A receiver (Zhao et al.;
reference notes gps-lnav-mm.md Sec. 2.2-2.3).  Each 1-ms epoch (one C/A code
period) is correlated with :func:`scintrack.signals.gps.correlator.epl`, using
the loop's own code error ``dtau`` (true minus replica delay, chips) and the
carrier phase / frequency errors of a carrier tracker (inputs).

Integration.  ``n = integration_ms`` consecutive 1-ms E and L outputs
(complex, I + jQ) are summed; ``n`` divides the 20-ms data bit and the
integrations are aligned with the bit edges: epoch e starts a new
integration when ``(e + first_in_bit) % n == 0``, ``first_in_bit`` being the
code period of epoch 0 within its bit (the dataset's ``first_epoch_in_bit``).
The data bits must be constant within every integration (checked).  A
leading or trailing partial integration gives no update (the loop coasts on
the aiding, as a receiver does until its first full integration).

Discriminator (noncoherent, normalised early-minus-late envelope)::

    D = (1 - Delta/2) (|L| - |E|) / (|L| + |E|)        (chips)

Gain derivation: noise-free, ``|E| ~ R(dtau + Delta/2) = 1 - Delta/2 - dtau``
and ``|L| ~ R(dtau - Delta/2) = 1 - Delta/2 + dtau`` for
``|dtau| <= min(Delta/2, 1 - Delta/2)``, so ``(|L|-|E|)/(|L|+|E|) = dtau /
(1 - Delta/2)``; the factor ``1 - Delta/2`` makes ``D = dtau`` exactly there
(unit slope at 0; Delta = 1 gives the notes' ``1/2 (|L|-|E|)/(|L|+|E|)``).
``|E| + |L| = 0`` gives ``D = 0``.  With noise the envelopes are Rician and
the mean slope drops below 1 at low ``C/N0 T`` (about 0.96 at 45 dB-Hz with
1 ms, 0.70 at 25 dB-Hz with 20 ms, Delta = 1); the gain is *not* rescaled by
a C/N0 estimate (as in ordinary receivers), so the loop bandwidth shrinks to
about ``slope * B_L`` in weak signal.

Carrier-tracker errors and code NCO.  The inputs ``phase_error_rad`` and
``freq_error_hz`` are the carrier tracker's estimate minus the truth
(replica minus true; ``epl`` receives their negatives, its true-minus-replica
``dphi`` and ``df``; the envelopes do not depend on that sign).  Aiding:
``f_code = 1.023e6 (1 + (f_D + f_err)/1575.42e6) + u`` chips/s, with
``f_D + f_err`` the tracker's Doppler estimate and ``u`` the loop correction,
so the code error obeys ``d(dtau)/dt = f_code - f_code,true = f_err/1540 + u``
(1540 = 1575.42e6 / 1.023e6): a replica running fast drifts early (``dtau``
grows).  ``f_err`` is constant within an epoch; ``dtau`` at an epoch is its
mid-epoch value (the correlator's convention) and the state is propagated
from start to start of epochs exactly.  Without carrier aiding
(``aiding_error_hz`` of :func:`run`) the NCO's Doppler term is a held value
``f_hold`` (the code Doppler at hand-over) instead of the tracker's
estimate, and ``d(dtau)/dt = (f_hold - f_D)/1540 + u``: the carrier
tracker then only wipes off the carrier of the correlator outputs.

Loop filter (first order).  After integration j the rate correction for the
whole of integration j+1 is ``u = -K D_j`` (the NCO integrates it: a
first-order loop).  Per integration of length ``T = n * 1 ms``, the mean
code error ``x_j`` then obeys ``x_{j+1} = x_j + r T - g (D_j + D_{j-1})/2``
(``r = f_err/1540`` the aiding ramp, ``g = K T``; a correction acts on half
of the integration it starts in, on average), i.e. ``H(z) = (g/2)(z+1) / (z^2 - (1 - g/2) z + g/2)``.  Its noise
bandwidth ``B_L = sum h^2 / (2T)`` is exactly ``g / (2 T (2 - g))`` (Jury's
second-order sum), the same as the textbook ``x_{j+1} = x_j - g D_j``, so

    ``g = 4 B_L T / (1 + 2 B_L T)``, ``K = g / T``  (-> ``4 B_L``, the analog
    first-order loop, for ``B_L T -> 0``)

(:func:`loop_gain`) and the linear-loop jitter is ``var(x) = 2 B_L T var(D)``
exactly.  Stable for ``0 < g < 2``; ``B_L T <= 0.25`` is required so the
closed forms (written for ``B_L T << 1``) stay meaningful.

Closed forms.  Thermal-noise jitter (Kaplan & Hegarty 2006, noncoherent
early-minus-late; notes Sec. 2.3)::

    sigma_tau^2 = B_L Delta / (2 C/N0) [1 + 2 / ((2 - Delta) T C/N0)]   (chips^2)

(:func:`thermal_jitter_chips`): the high-SNR expansion of ``2 B_L T var(D)``
with unit slope.  It holds within 2 % at 45 dB-Hz (the exact linear loop is
1.6 % below it with 1 ms, 0.1 % with 20 ms, where the per-epoch jitter adds
the within-integration ramp, ~g/6 in variance); at 25 dB-Hz, 20 ms it
still gives the noise referred to the input (``var(D)/slope^2``) within ~5 %
but, the slope being 0.70, the closed loop jitters less (tests quantify
both).  Steady-state lag of the first-order loop to the ramp ``r = f_err/1540``
chips/s: ``r / K`` (:func:`steady_state_lag_chips`; ``r T / g`` exactly).

Noise.  The same draws as :class:`~scintrack.signals.gps.correlator.NoiseStream`
(``stream.epochs(trials, sv, k0, k1)``): the E/L columns of the rows whose P
columns a carrier tracker of that (trial, sv) uses (the P columns are not
read), so code and carrier noises are correlated as the model says.  Trials are independent rows; the
kernel loops over them (serial, compiled with numba).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numba import njit

from scintrack.signals.gps import correlator
from scintrack.signals.gps.correlator import NoiseStream, epl

#: GPS L1 carrier and C/A chipping rate (Hz, chips/s) and their ratio.
F_L1 = 1575.42e6
F_CA = 1.023e6
CARRIER_PER_CHIP = F_L1 / F_CA  # 1540
#: One C/A code period: the correlator epoch (s).
CODE_PERIOD_S = 1e-3
#: Largest B_L T accepted (the closed forms are written for B_L T << 1).
MAX_BLT = 0.25
#: Data-bit length in code periods; integrations must divide it.
BIT_MS = 20


# --- closed forms ----------------------------------------------------------------------


def integration_time(integration_ms: int) -> float:
    """Integration length ``T`` (s) of ``integration_ms`` code periods (a divisor of the 20-ms bit)."""
    if int(integration_ms) != integration_ms or integration_ms < 1 or BIT_MS % int(integration_ms):
        raise ValueError(f"integration_ms must be one of 1, 2, 4, 5, 10, 20 (a divisor of the data bit; got {integration_ms!r})")
    return int(integration_ms) * CODE_PERIOD_S


def _check_bandwidth(bandwidth_hz: float, t_int: float) -> float:
    b = float(bandwidth_hz)
    if not (np.isfinite(b) and b > 0.0):
        raise ValueError(f"bandwidth_hz (B_L) must be a finite number > 0 Hz (got {bandwidth_hz!r})")
    if b * t_int > MAX_BLT:
        raise ValueError(f"bandwidth_hz * T = {b * t_int:g} > {MAX_BLT}: lower B_L or integration_ms (the loop needs B_L T << 1)")
    return b


def _check_spacing(spacing_chips: float) -> float:
    s = float(spacing_chips)
    if not (np.isfinite(s) and 0.0 < s < 2.0):
        raise ValueError(f"spacing_chips (early-late spacing Delta) must be in (0, 2) chips (got {spacing_chips!r})")
    return s


def discriminator_gain(spacing_chips: float) -> float:
    """``1 - Delta/2``: unit slope of the normalised E-L envelope at ``dtau = 0`` (module docstring)."""
    return 1.0 - 0.5 * _check_spacing(spacing_chips)


def loop_gain(bandwidth_hz: float, t_int: float) -> float:
    """Per-update gain ``g = K T = 4 B_L T / (1 + 2 B_L T)`` giving noise bandwidth ``B_L`` exactly."""
    t_int = float(t_int)
    if not (np.isfinite(t_int) and t_int > 0.0):
        raise ValueError(f"t_int must be a finite integration time > 0 s (got {t_int!r})")
    blt = _check_bandwidth(bandwidth_hz, t_int) * t_int
    return 4.0 * blt / (1.0 + 2.0 * blt)


def noise_bandwidth(g: float, t_int: float) -> float:
    """Noise bandwidth ``g / (2 T (2 - g))`` (Hz) of the loop with per-update gain ``g`` (inverse of :func:`loop_gain`)."""
    if not 0.0 < g < 2.0:
        raise ValueError(f"loop gain g must be in (0, 2) for a stable loop (got {g!r})")
    return g / (2.0 * t_int * (2.0 - g))


def thermal_jitter_chips(cn0_dbhz, bandwidth_hz: float, spacing_chips: float, t_int: float):
    """Kaplan & Hegarty noncoherent E-L code jitter (1 sigma, chips) at ``cn0_dbhz``, ``B_L``, ``Delta``, ``T``."""
    delta = _check_spacing(spacing_chips)
    b = _check_bandwidth(bandwidth_hz, t_int)
    cn0 = 10.0 ** (np.asarray(cn0_dbhz, dtype=float) / 10.0)
    return np.sqrt(b * delta / (2.0 * cn0) * (1.0 + 2.0 / ((2.0 - delta) * t_int * cn0)))


def steady_state_lag_chips(freq_error_hz, bandwidth_hz: float, t_int: float):
    """First-order-loop lag ``r / K`` (chips) to the ramp ``r = f_err / 1540`` of a constant aiding error ``f_err``."""
    k = loop_gain(bandwidth_hz, t_int) / t_int
    return np.asarray(freq_error_hz, dtype=float) / CARRIER_PER_CHIP / k


# --- the compiled loop -----------------------------------------------------------------


@njit(cache=True)
def discriminator(ie, qe, il, ql, gain):
    """``gain (|L| - |E|) / (|L| + |E|)`` of (possibly summed) early/late outputs; 0 if both are 0."""
    env_e = math.sqrt(ie * ie + qe * qe)
    env_l = math.sqrt(il * il + ql * ql)
    total = env_e + env_l
    if total == 0.0:
        return 0.0
    return gain * (env_l - env_e) / total


@njit(cache=True)
def dll_kernel(a, sigma, bits, phase_err, freq_err, aid_err, noise, spacing, n_int, offset, k_gain, disc_gain, dtau0, out):
    """Closed-loop DLL over ``out.shape = (trials, epochs)``; writes mid-epoch ``dtau`` (chips) into ``out``.

    ``a, sigma, bits, phase_err, freq_err`` (replica minus true): (trials,
    epochs) (broadcast views allowed); ``aid_err``: (trials, epochs) error of
    the code NCO's rate aid (Hz of carrier; ``freq_err`` for a carrier-aided
    loop); ``noise``: (trials, epochs, 6);
    ``offset``: code periods of the first integration already elapsed at
    epoch 0 (that partial integration gives no update); ``k_gain``: K (1/s);
    ``dtau0``: (trials,) code error at the start of epoch 0.
    """
    n_tr, n_ep = out.shape
    buf = np.empty(6)
    t1 = CODE_PERIOD_S
    for t in range(n_tr):
        start = dtau0[t]  # code error at the start of the current epoch
        u = 0.0  # loop correction of the code rate (chips/s)
        ie = qe = il = ql = 0.0
        m = offset
        partial = offset > 0
        for e in range(n_ep):
            rate = aid_err[t, e] / CARRIER_PER_CHIP + u
            mid = start + 0.5 * rate * t1
            out[t, e] = mid
            epl(a[t, e], bits[t, e], mid, -phase_err[t, e], -freq_err[t, e], t1, spacing, noise[t, e], buf, sigma[t, e])
            ie += buf[0]
            il += buf[2]
            qe += buf[3]
            ql += buf[5]
            start += rate * t1
            m += 1
            if m == n_int:
                if not partial:
                    u = -k_gain * discriminator(ie, qe, il, ql, disc_gain)
                partial = False
                ie = qe = il = ql = 0.0
                m = 0


# --- drivers ---------------------------------------------------------------------------


def _as_grid(value, shape: tuple[int, int], arg: str, check=None) -> np.ndarray:
    """``value`` as a read-only (trials, epochs) view; ``check`` (and finiteness) is tested on ``value``
    before broadcasting, so a per-epoch row is checked once, not once per trial."""
    v = np.asarray(value, dtype=float)
    try:
        grid = np.broadcast_to(v, shape)
    except ValueError:
        raise ValueError(f"{arg} must broadcast to (trials, epochs) = {shape} (got shape {v.shape})") from None
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{arg} must be finite")
    if check is not None:
        check(v)
    return grid


def _check_bits(bits, shape: tuple[int, int], n_int: int, first_in_bit: int) -> np.ndarray:
    def check(b):
        if not np.all(np.abs(b) == 1.0):
            raise ValueError("bits must be +-1 data bits, shape (epochs,) or (trials, epochs)")
        if b.ndim == 0 or b.shape[-1] < 2:
            return
        inside = (np.arange(1, shape[1]) + first_in_bit) % n_int != 0  # epoch e continues the integration of e-1
        if np.any((b[..., 1:] != b[..., :-1]) & inside):
            raise ValueError(f"bits change inside a {n_int}-ms integration: first_in_bit ({first_in_bit}) must put "
                             "integration boundaries on the bit edges")

    return _as_grid(bits, shape, "bits", check)


def run(
    noise: np.ndarray,
    cn0_dbhz,
    bits,
    phase_error_rad,
    freq_error_hz,
    *,
    spacing_chips: float,
    bandwidth_hz: float,
    integration_ms: int = 1,
    first_in_bit: int = 0,
    dtau0_chips=0.0,
    gain: str = "agc",
    cn0_ref_dbhz=None,
    aiding_error_hz=None,
) -> np.ndarray:
    """Closed-loop code error ``dtau`` (trials, epochs) in chips (true minus replica delay, mid-epoch).

    ``noise``: unit-variance correlated E/P/L noise (trials, epochs, 6) in
    :data:`~scintrack.signals.gps.correlator.CHANNELS` order (e.g.
    ``NoiseStream.epochs``; zeros for a noise-free run).  ``cn0_dbhz``,
    ``bits`` (+-1), and the carrier tracker's errors, estimate minus truth,
    ``phase_error_rad`` (at the start of each epoch) and ``freq_error_hz``
    (also the aiding error) broadcast to (trials, epochs).
    ``integration_ms``: code periods per discriminator update (1, 2, 4, 5,
    10 or 20); ``first_in_bit``: code period of epoch 0 within its 20-ms bit
    (0 = bit edge).  ``dtau0_chips``: scalar or (trials,) code error at the
    start of epoch 0.  ``gain``/``cn0_ref_dbhz``: the correlator's normalisation.
    ``aiding_error_hz``: error (estimate minus truth, Hz of carrier) of the
    Doppler that sets the code NCO's rate, broadcast to (trials, epochs);
    ``None`` (a carrier-aided loop) uses ``freq_error_hz``.  A loop without
    carrier aiding holds the code Doppler it started with, so its aiding
    error is that start value minus the true Doppler (a rate-only loop: the
    first-order filter's correction ``u`` alone follows the Doppler's change,
    with the lag ``r / K`` of :func:`steady_state_lag_chips`).
    """
    noise = np.asarray(noise, dtype=np.float64)
    if noise.ndim != 3 or noise.shape[-1] != 6:
        raise ValueError(f"noise must have shape (trials, epochs, 6) in the order {correlator.CHANNELS} (got {noise.shape})")
    shape = noise.shape[:2]
    t_int = integration_time(integration_ms)
    n_int = int(integration_ms)
    if int(first_in_bit) != first_in_bit or not 0 <= first_in_bit < BIT_MS:
        raise ValueError(f"first_in_bit must be the code period of epoch 0 within its bit, 0..{BIT_MS - 1} (got {first_in_bit!r})")
    delta = _check_spacing(spacing_chips)
    k_gain = loop_gain(bandwidth_hz, t_int) / t_int
    # The gains of the C/N0 as given (a per-epoch row, usually), broadcast to the grid afterwards: the same
    # values element by element as computing them on the (trials, epochs) grid, without two grid-sized
    # arrays per call (~0.1-0.4 s a call, 16 calls per Zhao sweep point).
    _as_grid(cn0_dbhz, shape, "cn0_dbhz")
    a, sigma = correlator.gains(np.asarray(cn0_dbhz, dtype=float), CODE_PERIOD_S, gain, cn0_ref_dbhz)
    dtau0 = np.asarray(dtau0_chips, dtype=float)
    if dtau0.shape not in ((), (shape[0],)) or not np.all(np.isfinite(dtau0)):
        raise ValueError(f"dtau0_chips must be a finite scalar or one value per trial, shape ({shape[0]},) (got {dtau0.shape})")
    dtau0 = np.array(np.broadcast_to(dtau0, shape[:1]))
    out = np.empty(shape)
    dll_kernel(
        _as_grid(a, shape, "a"), _as_grid(sigma, shape, "sigma"), _check_bits(bits, shape, n_int, int(first_in_bit)),
        _as_grid(phase_error_rad, shape, "phase_error_rad"), _as_grid(freq_error_hz, shape, "freq_error_hz"),
        _as_grid(freq_error_hz if aiding_error_hz is None else aiding_error_hz, shape, "aiding_error_hz"),
        np.ascontiguousarray(noise), delta, n_int, int(first_in_bit) % n_int, k_gain, discriminator_gain(delta), dtau0, out,
    )
    return out


def track(
    stream: NoiseStream,
    trials: Sequence[int] | int,
    sv: int,
    k0: int,
    cn0_dbhz,
    bits,
    phase_error_rad,
    freq_error_hz,
    *,
    bandwidth_hz: float,
    integration_ms: int = 1,
    first_in_bit: int = 0,
    dtau0_chips=0.0,
    gain: str = "agc",
    cn0_ref_dbhz=None,
) -> np.ndarray:
    """:func:`run` on epochs ``k0 .. k0+n-1`` of (``trials``, ``sv``) of ``stream`` (its spacing); ``n`` = ``bits.shape[-1]``."""
    if not isinstance(stream, NoiseStream):
        raise ValueError("stream must be a correlator.NoiseStream (the E/P/L noise of the dataset)")
    n = np.shape(bits)[-1] if np.ndim(bits) else 0
    if n < 1:
        raise ValueError("bits must be a (epochs,) or (trials, epochs) array of +-1 with epochs >= 1")
    noise = stream.epochs(trials, sv, k0, k0 + n)
    return run(
        noise, cn0_dbhz, bits, phase_error_rad, freq_error_hz, spacing_chips=stream.spacing, bandwidth_hz=bandwidth_hz,
        integration_ms=integration_ms, first_in_bit=first_in_bit, dtau0_chips=dtau0_chips, gain=gain, cn0_ref_dbhz=cn0_ref_dbhz,
    )
