"""Multi-frequency scintillation from a drifting 1-D power-law phase screen.

The physics-based stand-in for the JRC Hanoi traces (Vila-Valls 2018,
Sec. VI-E), in the family of Rino's and Carrano's phase-screen models:

1. **Screen.**  A 1-D phase screen ``phi(x)`` at L1 whose power spectrum is
   a power law with an outer scale, ``Phi(kappa) ~ (kappa_0^2 + kappa^2)^(-p/2)``
   (``p`` the 1-D spectral index, ``kappa_0 = 2 pi / L_0``), drawn as white
   Gaussian noise shaped in the Fourier domain (periodic, so the FFT
   propagation below has no edge effect).  A slowly varying envelope
   ``g(x) >= 0`` scales the screen to give an event its S4 profile (a
   turbulence strength that changes along the drift).
2. **Frequency scaling.**  The ionospheric phase is proportional to TEC/f, so
   the screen at carrier ``f`` is ``phi(x) f_L1 / f``.
3. **Propagation.**  The field ``exp(j phi_f(x))`` leaving the screen is
   propagated a distance ``z`` to the ground with the Fresnel transfer
   function ``exp(-j kappa^2 z / (2 k_f))``, ``k_f = 2 pi f / c`` (paraxial
   diffraction, exact for a thin screen); energy is conserved, so the mean
   received intensity is 1 without normalisation.
4. **Drift.**  The pattern drifts past the receiver at ``v`` m/s, so a time
   series at ``Ts`` is the field sampled every ``dx = v Ts`` metres.

Amplitude ``rho = |U|`` and phase ``theta = unwrap(arg U)`` then carry the
canonical features of real strong scintillation: deep fades with phase
jumps, L2/L5 (lower frequencies) scintillating more than L1, and
band-to-band correlation.  Calibration (:func:`calibrate`) chooses the
screen strength and spectral index so that the event's mean S4 and
sigma_phi at L1 come out as configured.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..estimators.s4 import window_s4  # S4 lives in estimators.s4 (re-exported here)
from ..estimators.sigma_phi import detrend_phase, window_sigma_phi  # noqa: F401  (sigma_phi lives in estimators.sigma_phi; re-exported here)

C_LIGHT = 299_792_458.0
GPS_CARRIERS_HZ = {"L1": 1575.42e6, "L2": 1227.60e6, "L5": 1176.45e6}


@dataclass(frozen=True)
class ScreenGeometry:
    """Where the screen is and how it moves."""

    height_m: float = 350e3  # screen-to-receiver distance z
    drift_m_s: float = 100.0  # effective drift velocity of the pattern
    outer_scale_m: float = 10e3  # L_0


def white_spectrum(rng: np.random.Generator, n: int) -> np.ndarray:
    """Complex white Gaussian spectrum of a real length-``n`` series (rfft layout)."""
    m = n // 2 + 1
    w = rng.normal(size=m) + 1j * rng.normal(size=m)
    w[0] = 0.0
    return w


def shaped_screen(white: np.ndarray, n: int, dx: float, spectral_index: float, outer_scale_m: float) -> np.ndarray:
    """Unit-variance screen with a power-law spectrum of index ``spectral_index``."""
    kappa = 2 * np.pi * np.fft.rfftfreq(n, dx)
    k0 = 2 * np.pi / outer_scale_m
    amp = (k0**2 + kappa**2) ** (-spectral_index / 4.0)
    phi = np.fft.irfft(white * amp, n)
    return phi / phi.std()


def fresnel_propagate(phase: np.ndarray, dx: float, carrier_hz: float, height_m: float) -> np.ndarray:
    """Complex field on the ground below a thin phase screen (periodic FFT propagation)."""
    field = np.empty(phase.shape, dtype=complex)
    _unit_phasor(np.ascontiguousarray(phase, dtype=float).ravel(), field.ravel())
    return np.fft.ifft(np.fft.fft(field) * _fresnel_transfer(phase.size, dx, carrier_hz, height_m))


@njit(cache=True)
def _unit_phasor(phase, out):
    """``out = exp(j phase)`` (1-D) as ``numpy.exp(1j * phase)`` gives it: libm's ``cos`` and ``sin``, the values
    numpy's complex ``exp`` of an imaginary argument returns (``tests/test_surrogate.py``: bit for bit),
    without its complex temporary; a calibration propagates a few hundred screens."""
    for i in range(phase.size):
        x = phase[i] + 0.0  # the imaginary part of numpy's 1j * phase: -0.0 becomes +0.0, every other value stays
        out[i] = complex(math.cos(x), math.sin(x))


@functools.lru_cache(maxsize=8)
def _fresnel_transfer(n: int, dx: float, carrier_hz: float, height_m: float) -> np.ndarray:
    """The Fresnel transfer function ``exp(-i kappa^2 h / (2 k))`` on the screen's FFT grid (read-only; the same for
    every propagation of a calibration, which propagates a few hundred screens of one size)."""
    k = 2 * np.pi * carrier_hz / C_LIGHT
    kappa = 2 * np.pi * np.fft.fftfreq(n, dx)
    transfer = np.exp(-1j * kappa**2 * height_m / (2 * k))
    transfer.setflags(write=False)
    return transfer


def envelope(profile: Sequence[Sequence[float]], n: int, ts: float) -> np.ndarray:
    """Piecewise-linear strength profile ``[[t_s, relative_strength], ...]`` sampled at ``Ts``."""
    pts = np.asarray(profile, dtype=float)
    return np.interp(np.arange(n) * ts, pts[:, 0], pts[:, 1])


@dataclass
class Event:
    """One multi-frequency event: amplitude/phase per band and the screen settings."""

    rho: dict[str, np.ndarray]
    theta: dict[str, np.ndarray]
    strength_rad: float
    spectral_index: float


def band_field(unit_screen: np.ndarray, env: np.ndarray, strength_rad: float, dx: float, band: str, geometry: ScreenGeometry, margin: int) -> np.ndarray:
    """Complex field on the ground at ``band`` for one screen realisation; ``margin`` samples are dropped at both ends."""
    phi_l1 = strength_rad * env * unit_screen
    f = GPS_CARRIERS_HZ[band]
    return fresnel_propagate(phi_l1 * GPS_CARRIERS_HZ["L1"] / f, dx, f, geometry.height_m)[margin : unit_screen.size - margin]


def propagate_event(unit_screen: np.ndarray, env: np.ndarray, strength_rad: float, dx: float, bands: Sequence[str], geometry: ScreenGeometry, margin: int) -> Event:
    """Amplitude and unwrapped phase at every band (:func:`band_field`) for one screen realisation."""
    rho, theta = {}, {}
    for band in bands:
        u = band_field(unit_screen, env, strength_rad, dx, band, geometry, margin)
        rho[band] = np.abs(u)
        th = np.unwrap(np.angle(u))
        theta[band] = th - th[0]
    return Event(rho=rho, theta=theta, strength_rad=strength_rad, spectral_index=float("nan"))


def _bisect(fun, lo: float, hi: float, target: float, iters: int, what: str) -> float:
    """Argument in [lo, hi] where the monotone ``fun`` (either direction) equals ``target``."""
    f_lo, f_hi = fun(lo), fun(hi)
    if not (min(f_lo, f_hi) <= target <= max(f_lo, f_hi)):
        raise ValueError(f"{what} = {target:g} is outside what the phase screen reaches here ({min(f_lo, f_hi):.3g} .. {max(f_lo, f_hi):.3g})")
    rising = f_hi >= f_lo
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        if (fun(mid) < target) == rising:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def calibrate(
    white: np.ndarray,
    n: int,
    env: np.ndarray,
    *,
    ts: float,
    geometry: ScreenGeometry,
    s4_target: float,
    sigma_phi_target: float,
    window_s: float,
    margin: int,
    index_grid: Sequence[float] = tuple(np.round(np.arange(2.0, 4.51, 0.1), 2)),
    iters: int = 16,
    sigma_tolerance: float = 0.1,
    detrend_hz: float = 0.1,
) -> tuple[float, float]:
    """Screen strength (rad rms at L1 for envelope 1) and spectral index giving the
    event's mean window S4 and mean window sigma_phi at L1.

    For a fixed spectral index the mean S4 grows monotonically with the
    strength up to saturation, so the strength is found by bisection on its
    logarithm.  sigma_phi at that S4 depends on the index, but not
    monotonically (measured: at S4 = 0.9 and 200 m/s it falls from 2.3 rad
    at p = 2 to 1.6 at p = 3 and rises again to 1.75 at p = 4.5), so the
    index is chosen on a grid (step 0.1) as the one whose sigma_phi is
    nearest the target; a target further than ``sigma_tolerance`` (relative)
    from every grid point is an error.  The white-noise realisation is fixed
    throughout, so the search is deterministic.
    """
    dx = geometry.drift_m_s * ts
    per = int(round(window_s / ts))
    best = None
    for index in index_grid:
        unit = shaped_screen(white, n, dx, float(index), geometry.outer_scale_m)

        def s4_of(log_strength: float, unit=unit) -> float:  # the amplitude only: no phase unwrapping in the search
            u = band_field(unit, env, float(np.exp(log_strength)), dx, "L1", geometry, margin)
            return float(window_s4(np.abs(u) ** 2, per).mean())

        try:
            strength = float(np.exp(_bisect(s4_of, np.log(0.01), np.log(200.0), s4_target, iters, "S4 at L1")))
        except ValueError:
            continue
        ev = propagate_event(unit, env, strength, dx, ["L1"], geometry, margin)
        sig = float(window_sigma_phi(ev.theta["L1"], ts, per, detrend_hz).mean())
        if best is None or abs(sig - sigma_phi_target) < abs(best[2] - sigma_phi_target):
            best = (strength, float(index), sig)
    if best is None:
        raise ValueError(f"S4 at L1 = {s4_target:g} is not reachable by the phase screen (saturation near 1)")
    if abs(best[2] - sigma_phi_target) > sigma_tolerance * sigma_phi_target:
        raise ValueError(
            f"sigma_phi at L1 = {sigma_phi_target:g} rad is not reachable at S4 = {s4_target:g} with this geometry "
            f"(nearest {best[2]:.3g} rad at spectral index {best[1]:g}); change sigma_phi_l1 or drift_m_s"
        )
    return best[0], best[1]
