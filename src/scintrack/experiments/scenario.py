"""Scenarios as data: scintillation profile, C/N0 and dynamics -> truth and prompts.

A scenario is a config entry (with the common ``tracking`` settings: C/N0,
amplitude, f_d0, f_r; and the sampling period Ts)::

    s4_0.9_tau0_0.1: {duration_s: 60, segments: [{start_s: 0, s4: 0.9, tau0: 0.1}]}
    free:            {duration_s: 60, segments: []}        # no scintillation
    ar_0.5:          {duration_s: 60, scintillation_model: ar, segments: [...]}

``scintillation_model: ar`` draws the scintillation from the fitted AR models
instead of the CSM (an isolating experiment: the AEKF-AR's model is exact),
those of the nearest grid point of the table: the config must ask for a
point within the look-up tolerance (:mod:`scintrack.validity`), and the
point used is the truth recorded (``s4_t``, ``tau0_t`` and
``Realisation.model_point``).
A recorded (real or surrogate) trace is passed to :func:`simulate` as
``trace=(rho, theta)``, its phase already referenced by the caller;
``dynamics=False`` gives the static, dynamics-free case of Sec. VI-E2
(theta_d = 0).  :func:`acquisition` gives the trackers' initial values.

A scenario may override the shared dynamics (``fd0_hz``, ``fr_hz_s``) and
add a receiver oscillator, ``clock: <preset>`` of
:mod:`scintrack.models.clock`, whose exact two-state phase noise (in rad,
its own seed stream per trial) is part of ``theta_d``: the phase every
tracker must follow (Susi et al. 2014 process their data with an OCXO and a
rubidium clock).  ``scintillation_model: trace`` scenarios (Susi's 1-ms
cases) take the scintillation from a recorded trace passed as ``trace``;
their ``ts`` and ``tracking`` overrides are applied by the caller
(:func:`effective_tracking`, :mod:`.runner`).

``csm_phase: wrapped`` (reading R2 of the Vila-Valls simulation)
takes theta_s as the wrapped angle of the CSM field, arg z in (-pi, pi],
instead of its unwrapped phase.  The prompts are the same (``exp(j theta)``
is 2 pi-periodic); only the decomposition of the truth changes.
:meth:`Realisation.noise_reference` gives, on demand, the samples of a
correlator that carries no signal (its own seed stream, the prompts' noise
power), for the AEKF-AR's ``noise_estimate: reference``.
``realisations_of: <scenario>`` draws the seed streams of that scenario, so
a reading of the same case sees exactly the same realisations.

:func:`simulate` draws, for a list of trial indices, the initial phase, the
CSM scintillation and the thermal noise from independent seed streams named
after the scenario, so trial k is identical whichever shard or experiment
runs it (experiments that share a scenario see the same realisations).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..models.ar import ScintillationAR
from ..models.lut import scintillation_ar
from ..settings import EXPERIMENT_KEYS, TrackingSettings
from ..signals.correlator import complex_noise, noise_power, prompts
from ..signals.csm import Segment, generate_csm, generate_csm_profile, wrapped_phase
from ..signals.dynamics import initial_phases, third_order_phase


@dataclass
class Realisation:
    """Everything one shard of trials needs: truth, observations, settings."""

    trials: np.ndarray
    ts: float
    theta_d: np.ndarray
    theta_s: np.ndarray
    rho_s: np.ndarray
    y: np.ndarray
    noise_power: float
    s4_t: np.ndarray
    tau0_t: np.ndarray
    fd0_hz: float = 0.0
    seed: int = 0
    name: str = ""
    #: ``scintillation_model: ar``: the (S4, tau0) of the look-up-table point whose models drew the scintillation
    #: (the nearest grid point, within the look-up tolerance of the request: scintrack.validity); None otherwise
    model_point: tuple[float, float] | None = None

    @property
    def time(self) -> np.ndarray:
        return np.arange(self.y.shape[1]) * self.ts

    def noise_reference(self) -> np.ndarray:
        """Signal-free correlator samples CN(0, noise_power), one seed stream per trial."""
        return complex_noise(self.seed, f"scenario/{self.name}/noise_reference", self.trials, self.y.shape[1], self.noise_power)


def segments_of(scenario: Mapping[str, Any]) -> list[Segment]:
    return [Segment(float(s["start_s"]), float(s["s4"]), float(s["tau0"])) for s in scenario.get("segments", [])]


def ar_scintillation(seed: int, name: str, trials: np.ndarray, n_epochs: int, model: ScintillationAR, burn: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    """Scintillation drawn from the fitted AR models themselves (isolating experiment).

    ``theta_s`` from AR(p) (eq. 9) and ``rho_s`` from AR(q) with constant
    kappa (eq. 10), exactly the model the AEKF-AR assumes
    (:meth:`~scintrack.models.ar.ScintillationAR.simulate`), one seed stream per trial.
    """
    from ..seeding import rng_for

    theta = np.empty((trials.size, n_epochs))
    rho = np.empty((trials.size, n_epochs))
    for row, trial in enumerate(trials):
        theta[row], rho[row] = model.simulate(n_epochs, rng_for(seed, name, int(trial)), burn=burn)
    return theta, rho


def effective_tracking(scenario: Mapping[str, Any], tracking: Mapping[str, Any]) -> TrackingSettings:
    """The experiment's tracking settings (:data:`.settings.EXPERIMENT_KEYS` required) with the scenario's
    own ``tracking`` overrides (e.g. the estimator windows in epochs of a 1-ms scenario)."""
    return TrackingSettings.from_params({**tracking, **dict(scenario.get("tracking", {}))}, require=EXPERIMENT_KEYS)


def scenario_dynamics(scenario: Mapping[str, Any], tracking: TrackingSettings) -> tuple[float, float]:
    """(f_d0 [Hz], f_r [Hz/s]): the scenario's own values, else the shared ones."""
    return float(scenario.get("fd0_hz", tracking.fd0_hz)), float(scenario.get("fr_hz_s", tracking.fr_hz_s))


def clock_phase(seed: int, name: str, trials: np.ndarray, n_epochs: int, ts: float, preset: str) -> np.ndarray:
    """Receiver-oscillator carrier phase [rad] (trials, epochs), exact two-state model, one stream per trial."""
    from ..models import clock as clock_models
    from ..seeding import rng_for

    model = clock_models.preset(preset)
    out = np.empty((trials.size, n_epochs))
    for row, trial in enumerate(trials):
        out[row] = clock_models.simulate(model, ts, n_epochs, rng_for(seed, name, int(trial)), units="rad")[0]
    return out


def scenario_epochs(scenario: Mapping[str, Any], ts: float) -> int:
    """Epochs of a scenario at ``ts`` (what :func:`simulate` generates)."""
    return int(round(float(scenario["duration_s"]) / ts))


def acquisition(real: Realisation, tracking: TrackingSettings, static: bool = False):
    """Initial values every tracker gets: phase of the first prompt, nominal Doppler, zero rate.

    ``static``: the dynamics are known to be zero (phase, Doppler and rate 0).
    """
    from ..trackers.base import TrackInit

    n = real.y.shape[0]
    if static:
        return TrackInit(phase=np.zeros(n), doppler_hz=np.zeros(n), rate_hz_s=np.zeros(n))
    return TrackInit(
        phase=np.angle(real.y[:, 0]),
        doppler_hz=np.full(n, float(real.fd0_hz)),
        rate_hz_s=np.zeros(n),
    )


def simulate(
    name: str, scenario: Mapping[str, Any], tracking: TrackingSettings, *, seed: int, ts: float, nspa: int, warmup_s: float,
    trials: Sequence[int], lut=None, trace: tuple[np.ndarray, np.ndarray] | None = None, dynamics: bool = True,
) -> Realisation:
    n_epochs = scenario_epochs(scenario, ts)
    trials = np.asarray(list(trials))
    name = str(scenario.get("realisations_of", name))  # the seed streams (another scenario's realisations)
    amp = tracking.amplitude
    cn0 = float(scenario.get("cn0_dbhz", tracking.cn0_dbhz))
    fd0, fr = scenario_dynamics(scenario, tracking)
    if dynamics:
        theta0 = initial_phases(seed, f"scenario/{name}/theta0", trials)
        theta_d = third_order_phase(theta0, n_epochs, ts, fd0, fr)
        if scenario.get("clock"):
            theta_d = theta_d + clock_phase(seed, f"scenario/{name}/clock", trials, n_epochs, ts, str(scenario["clock"]))
    else:
        theta_d = np.zeros((trials.size, n_epochs))
    segs = segments_of(scenario)
    warmup = int(round(warmup_s / ts))
    model_point = None
    if trace is None and scenario.get("scintillation_model") == "trace":
        raise ValueError(f"scenario {name!r}: scintillation_model trace needs its trace (the experiment rule passes it)")
    if trace is not None:
        rho_1, theta_1 = (np.asarray(v, dtype=float) for v in trace)
        if rho_1.size < n_epochs:
            raise ValueError(f"scenario {name!r}: the trace has {rho_1.size} samples, the scenario needs {n_epochs}")
        rho = np.broadcast_to(rho_1[:n_epochs], (trials.size, n_epochs)).copy()
        theta_s = np.broadcast_to(theta_1[:n_epochs], (trials.size, n_epochs)).copy()
        s4_t = np.full(n_epochs, np.nan)
        tau0_t = np.full(n_epochs, np.nan)
    elif not segs:
        rho = np.ones((trials.size, n_epochs))
        theta_s = np.zeros((trials.size, n_epochs))
        s4_t = np.zeros(n_epochs)
        tau0_t = np.full(n_epochs, np.nan)
    elif scenario.get("scintillation_model", "csm") == "ar":
        if len(segs) != 1 or lut is None:
            raise ValueError(f"scenario {name!r}: an AR scintillation model needs one segment and the AR look-up table")
        model = scintillation_ar(lut, segs[0].s4, segs[0].tau0)
        theta_s, rho = ar_scintillation(seed, f"scenario/{name}/ar", trials, n_epochs, model)
        model_point = (float(model.s4), float(model.tau0))
        s4_t, tau0_t = np.full(n_epochs, model_point[0]), np.full(n_epochs, model_point[1])  # the point used, not the request
    elif len(segs) == 1:
        rho, theta_s = generate_csm(seed=seed, name=f"scenario/{name}/csm", trials=trials, n_epochs=n_epochs, ts=ts, s4=segs[0].s4, tau0=segs[0].tau0, nspa=nspa,
                                    warmup=warmup).polar()
        s4_t, tau0_t = np.full(n_epochs, segs[0].s4), np.full(n_epochs, segs[0].tau0)
    else:
        real, s4_t, tau0_t = generate_csm_profile(seed=seed, name=f"scenario/{name}/csm", trials=trials, n_epochs=n_epochs, ts=ts, segments=segs, nspa=nspa, warmup=warmup)
        rho, theta_s = real.polar()
    if scenario.get("csm_phase", "unwrapped") == "wrapped":
        theta_s = wrapped_phase(theta_s)
    s2 = noise_power(cn0, ts, amp)
    noise = complex_noise(seed, f"scenario/{name}/noise", trials, n_epochs, s2)
    y = prompts(theta_d + theta_s, rho, noise, amp, out=noise)  # in place: no second (trials, epochs) complex array
    return Realisation(trials=trials, ts=ts, theta_d=theta_d, theta_s=theta_s, rho_s=rho, y=y, noise_power=s2, s4_t=s4_t, tau0_t=tau0_t, fd0_hz=fd0,
                       seed=int(seed), name=name, model_point=model_point)
