"""Oscillator clock models from power-law h-coefficients (one implementation, two papers).

Used by Zhao et al.'s multiple-model Kalman filter (the jammed GPS dataset,
paper eqs. 1-5) and by Susi et al. 2014's KF PLLs (OCXO / rubidium process
noise).  Reference notes: ``/work/shared/notes/algorithms.md`` §3.6.

Units.  A :class:`ClockModel` holds the *fractional-frequency* coefficients of
the one-sided PSD ``S_y(f) = h0 + h_-1 / f + h_-2 / f^2`` (dimensionless, as in
the Allan-variance literature).  The two-state model is (time deviation x [s],
fractional frequency y [s/s]) driven by white noises of two-sided PSD
``S_f = h0 / 2`` (white FM -> random-walk phase) and ``S_g = 2 pi^2 h_-2``
(random-walk FM), so that the model's Allan variance is exactly
``h0 / (2 tau) + (2 pi^2 / 3) h_-2 tau``.  :func:`process_noise` and
:func:`simulate` rescale to the carrier phase: ``units='s'`` (x in s, y in
s/s), ``'cycles'`` (x f0 in cycles, y f0 in Hz), ``'rad'`` (rad, rad/s) or
``'m'`` (x c in m, y c in m/s), i.e. Q is multiplied by 1, f0^2, (2 pi f0)^2 or
c^2 (f0 = L1 by default).

Zhao's TCXO.  The paper gives ``h0 = 4.9639e-3``, ``h_-2 = 7.4458e-6`` without
units.  With f_L1 = 1575.42 MHz, ``4.9639e-3 / f_L1^2 = 2.0000e-21`` and
``7.4458e-6 / f_L1^2 = 3.0000e-24`` (checked in ``tests/test_clock.py``): they
are fractional h's multiplied by f_L1^2, i.e. the coefficients of the phase
PSD in cycles^2.  We adopt this reading (preset ``"zhao_tcxo"`` stores the
paper's numbers divided by f_L1^2, so the cycles-unit Q reproduces them
exactly).  The fractional values equal the "high quality TCXO" h0 = 2e-21
together with an h_-2 = 3e-24 that also appears for that oscillator class in
some public transcriptions of the same table (others give 2e-20).  In cycles,
``S_f = 2.482e-3 cycles^2 s`` and ``S_g = 1.470e-4 cycles^2 / s^3``:

* white-FM phase random walk: sigma = 1.58e-3 cycles (9.9 mrad) per 1 ms,
  7.05e-3 cycles (44 mrad) per 20 ms, 0.050 cycles after 1 s;
* random-walk FM: frequency sigma = sqrt(S_g t) = 0.0121 Hz after 1 s and
  0.188 Hz after 240 s (phase sigma 26 cycles after 240 s from a known
  state, dominated by the integrated frequency walk).

Process noise.  :func:`process_noise` is the exact discrete Q of the
continuous model (Brown & Hwang, 4th ed., §9.3):
``Q = [[S_f dt + S_g dt^3/3, S_g dt^2/2], [S_g dt^2/2, S_g dt]]``.
:func:`process_noise_zhao_eq3` is Zhao's eq. (3) (from Chan et al. 2014) as
written: its (3,3) entry ``S_f / dt + 4/3 S_g dt`` is not the variance of the
instantaneous frequency increment but of the frequency averaged over the
interval (the white-FM term enters it as ``S_f / dt``); it coincides with the
h_-1 = 0 case of the approximate "QD" matrix quoted from Brown & Hwang in
public GNSS code.  The Zhao form is provided so the filter of the paper can be
reproduced; the dataset's truth uses the exact model.

Flicker FM (h_-1) is neglected by the two-state model: 1/f noise has no
finite-dimensional Markov representation.  The approximations seen in public
code (adding ``2 h_-1 dt^2`` to q11 and ``4 h_-1`` to q22) add a
step-size-dependent variance, so they change the process when dt changes; we
do not use them.  :func:`allan_variance` keeps the flicker floor
``2 ln 2 h_-1`` (it is the closed form of the full power-law model), so
``allan_variance(model.without_flicker(), tau)`` is what :func:`simulate`
reproduces.  At tracking time scales (tau = 10 ms) the floor is <= 9 % of the
Allan variance for every preset (OCXO 9 %, others < 1 %); near the minimum of
the other two terms it is 4 % (low TCXO) and 0.6 % (high TCXO) but 0.8x, 1.2x
and 3.5x of it for the OCXO, rubidium and cesium presets, so their two-state
Q understates the stability floor at tau ~ 0.1 s .. 1 day.

Presets (:data:`PRESETS`, values from Brown & Hwang, *Introduction to Random
Signals and Applied Kalman Filtering*, 4th ed., §9.3 p. 327, as transcribed in
public GNSS code and in algorithms.md §3.6): TCXO low / high quality, OCXO,
rubidium, cesium, plus Zhao's TCXO.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

F_L1_HZ = 1575.42e6
SPEED_OF_LIGHT_M_S = 299_792_458.0
UNITS = ("cycles", "rad", "m", "s")

_BH = "Brown & Hwang 4th ed. §9.3 p. 327 (algorithms.md §3.6)"


def _positive(value: float, arg: str) -> float:
    value = float(value)
    if not (np.isfinite(value) and value > 0.0):
        raise ValueError(f"{arg} must be a finite number > 0 (got {value!r})")
    return value


@dataclass(frozen=True)
class ClockModel:
    """Power-law oscillator: fractional-frequency ``h0``, ``h_-1`` (``h_m1``), ``h_-2`` (``h_m2``)."""

    h0: float
    h_m1: float
    h_m2: float
    name: str = "custom"
    source: str = ""

    def __post_init__(self):
        for field in ("h0", "h_m1", "h_m2"):
            value = getattr(self, field)
            if not (np.isfinite(value) and value >= 0.0):
                raise ValueError(f"ClockModel.{field} must be a finite number >= 0 (got {value!r})")

    @property
    def s_f(self) -> float:
        """White-FM PSD ``h0 / 2`` (s^2 per s of the time deviation)."""
        return self.h0 / 2.0

    @property
    def s_g(self) -> float:
        """Random-walk-FM PSD ``2 pi^2 h_-2`` (s^2/s^2 per s of the fractional frequency)."""
        return 2.0 * math.pi**2 * self.h_m2

    def without_flicker(self) -> ClockModel:
        """The same model with ``h_-1 = 0`` (what the two-state model represents)."""
        return replace(self, h_m1=0.0)

    @classmethod
    def from_phase_coefficients(cls, h0_cycles: float, h_m2_cycles: float, carrier_hz: float = F_L1_HZ, **kw) -> ClockModel:
        """From h's of the carrier-phase PSD in cycles^2 (fractional h times ``carrier_hz^2``)."""
        f2 = _positive(carrier_hz, "carrier_hz") ** 2
        return cls(h0=h0_cycles / f2, h_m1=0.0, h_m2=h_m2_cycles / f2, **kw)


PRESETS: dict[str, ClockModel] = {
    "tcxo_low": ClockModel(2e-19, 7e-21, 2e-20, "tcxo_low", _BH),
    "tcxo_high": ClockModel(2e-21, 1e-22, 2e-20, "tcxo_high", _BH),
    "ocxo": ClockModel(2e-25, 7e-25, 6e-25, "ocxo", _BH),
    "rubidium": ClockModel(2e-22, 4.5e-26, 1e-30, "rubidium", _BH),
    "cesium": ClockModel(2e-22, 5e-27, 1.5e-33, "cesium", _BH),
    "zhao_tcxo": ClockModel.from_phase_coefficients(
        4.9639e-3, 7.4458e-6, name="zhao_tcxo", source="Zhao et al., MM Kalman filter under wideband jamming, Sec. Dynamic Model (h in cycles^2 at L1)"
    ),
}


def preset(name: str) -> ClockModel:
    """The named preset (:data:`PRESETS`)."""
    try:
        return PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown clock preset {name!r}; choose one of {sorted(PRESETS)}") from None


def unit_scale(units: str, carrier_hz: float = F_L1_HZ) -> float:
    """Factor from (s, s/s) to ``units``: 1, f0, 2 pi f0 or c (square it for variances)."""
    f0 = _positive(carrier_hz, "carrier_hz")
    scales = {"s": 1.0, "cycles": f0, "rad": 2.0 * math.pi * f0, "m": SPEED_OF_LIGHT_M_S}
    if units not in scales:
        raise ValueError(f"units must be one of {UNITS} (got {units!r})")
    return scales[units]


def transition(dt: float) -> np.ndarray:
    """State transition ``[[1, dt], [0, 1]]`` of (phase, frequency)."""
    return np.array([[1.0, _positive(dt, "dt")], [0.0, 1.0]])


def process_noise(model: ClockModel, dt: float, units: str = "cycles", carrier_hz: float = F_L1_HZ) -> np.ndarray:
    """Exact discrete Q of (phase, frequency) over ``dt`` (h_-1 neglected)."""
    dt = _positive(dt, "dt")
    sf, sg = model.s_f, model.s_g
    q = np.array([[sf * dt + sg * dt**3 / 3.0, sg * dt**2 / 2.0], [sg * dt**2 / 2.0, sg * dt]])
    return q * unit_scale(units, carrier_hz) ** 2


def process_noise_zhao_eq3(model: ClockModel, dt: float, units: str = "cycles", carrier_hz: float = F_L1_HZ) -> np.ndarray:
    """Zhao eq. (3) clock block as written: (3,3) = ``S_f/dt + 4/3 S_g dt`` (interval-averaged frequency)."""
    dt = _positive(dt, "dt")
    sf, sg = model.s_f, model.s_g
    q = np.array([[sf * dt + sg * dt**3 / 3.0, sg * dt**2 / 2.0], [sg * dt**2 / 2.0, sf / dt + 4.0 / 3.0 * sg * dt]])
    return q * unit_scale(units, carrier_hz) ** 2


def cholesky_2x2(q: np.ndarray) -> np.ndarray:
    """Lower Cholesky factor of a 2x2 PSD matrix, also when it is singular (e.g. h0 = 0)."""
    l11 = math.sqrt(max(q[0, 0], 0.0))
    l21 = q[1, 0] / l11 if l11 > 0.0 else 0.0
    l22 = math.sqrt(max(q[1, 1] - l21 * l21, 0.0))
    return np.array([[l11, 0.0], [l21, l22]])


def _generator(rng_or_seed) -> np.random.Generator:
    if isinstance(rng_or_seed, np.random.Generator):
        return rng_or_seed
    if isinstance(rng_or_seed, np.random.SeedSequence):
        return np.random.Generator(np.random.PCG64(rng_or_seed))
    if isinstance(rng_or_seed, int | np.integer) and rng_or_seed >= 0:
        return np.random.Generator(np.random.PCG64(int(rng_or_seed)))
    raise ValueError(f"rng_or_seed must be a numpy Generator, a SeedSequence or an int >= 0 (got {rng_or_seed!r})")


def simulate(
    model: ClockModel, dt: float, n: int, rng_or_seed, units: str = "cycles", trials: int | None = None, carrier_hz: float = F_L1_HZ
) -> tuple[np.ndarray, np.ndarray]:
    """Sample the exact discrete process: (phase, frequency) at ``t = k dt``, k = 0..n-1.

    Starts from phase = frequency = 0 (add the initial offsets outside).
    Shapes ``(n,)``, or ``(trials, n)`` when ``trials`` is given.  Each step
    adds ``w_k = L z_k`` with ``L L^T = Q`` (:func:`process_noise`).
    """
    dt = _positive(dt, "dt")
    if int(n) != n or n < 1:
        raise ValueError(f"n must be an integer >= 1 (got {n!r})")
    if trials is not None and (int(trials) != trials or trials < 1):
        raise ValueError(f"trials must be None or an integer >= 1 (got {trials!r})")
    chol = cholesky_2x2(process_noise(model, dt, units, carrier_hz))
    lead = () if trials is None else (int(trials),)
    z = _generator(rng_or_seed).standard_normal((*lead, int(n) - 1, 2))
    w = z @ chol.T
    freq = np.zeros((*lead, int(n)))
    np.cumsum(w[..., 1], axis=-1, out=freq[..., 1:])
    phase = np.zeros_like(freq)
    np.cumsum(freq[..., :-1] * dt + w[..., 0], axis=-1, out=phase[..., 1:])
    return phase, freq


def allan_variance(model: ClockModel, tau) -> np.ndarray:
    """Closed form ``h0/(2 tau) + 2 ln2 h_-1 + (2 pi^2/3) h_-2 tau`` (dimensionless)."""
    tau = np.asarray(tau, dtype=float)
    if not np.all(np.isfinite(tau) & (tau > 0.0)):
        raise ValueError("tau must be finite and > 0")
    return model.h0 / (2.0 * tau) + 2.0 * math.log(2.0) * model.h_m1 + (2.0 * math.pi**2 / 3.0) * model.h_m2 * tau


def allan_deviation(model: ClockModel, tau) -> np.ndarray:
    """``sqrt(allan_variance)``."""
    return np.sqrt(allan_variance(model, tau))
