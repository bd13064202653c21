"""What every tracker shares: the interface, the build context, the dynamics
model and the numpy forms of the discriminator and its variance.

Interface (:class:`Tracker`): ``tracker.run(y, init) -> TrackOutput`` where
``y`` holds complex prompt samples shaped (trials, epochs) and ``init`` the
acquisition values (initial phase and Doppler per trial).  ``run`` is the
compiled kernel; ``reference`` (same signature) is the textbook numpy form of
the same filter, one trial-vectorised time loop, used by the tests and the
benchmark.  A tracker type is registered in :mod:`.registry` and built from its
config entry by its ``from_spec(spec, context)``; :class:`TrackerContext` is
everything a spec may refer to besides its own keys.  What a tracker gives
besides ``theta_d`` (scintillation estimates, on-line S4, discriminator, ...)
it declares in ``PROVIDES`` and :meth:`Tracker.request`, with the names of
:data:`OUTPUT_NAMES`; the experiments read that declaration.

Dynamics model (eq. 8 with m = 3): state ``[theta_d (rad), f_d (Hz), f_r (Hz/s)]``,
``F_d = [[1, 2 pi T, pi T^2], [0, 1, T], [0, 0, 1]]``; process noise from a
white Doppler-jerk of PSD ``q`` (Hz^2/s^3):
``Q_d = q [[(2pi)^2 T^5/20, 2pi T^4/8, 2pi T^3/6], [2pi T^4/8, T^3/3, T^2/2], [2pi T^3/6, T^2/2, T]]``.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np

from . import blocks


@dataclass
class TrackInit:
    """Acquisition output handed to every tracker (one value per trial).

    ``bit_prior`` (optional): probability that the data level is d = +1 at each
    observation, shape (epochs,) or (trials, epochs); None means a pilot
    signal (d = +1 known).  Read by the multiple-model tracker
    (:mod:`.mm_kf`); the other trackers ignore it.

    ``noise_reference`` (optional): samples of a correlator that carries no
    signal (same noise power as the prompts, independent noise), shape
    (trials, epochs); read by the AEKF-AR with ``noise_estimate: reference``.
    """

    phase: np.ndarray
    doppler_hz: np.ndarray
    rate_hz_s: np.ndarray
    bit_prior: np.ndarray | None = None
    noise_reference: np.ndarray | None = None


@dataclass
class TrackOutput:
    """Estimates of the dynamics phase and optional extras, (trials, epochs).

    An extra that holds its value over runs of epochs may be a
    :class:`~.held_series.HeldSeries` (the SAKF's monitors): it reads as the
    (trials, epochs) array through ``numpy.asarray`` and indexing.
    """

    theta_d: np.ndarray
    extras: dict[str, np.ndarray] = field(default_factory=dict)


#: The optional outputs of a tracker (keys of ``TrackOutput.extras``), shaped (trials, epochs) unless said.
OUTPUT_NAMES = {
    "total_phase": "estimate of the total carrier phase theta_d + theta_s (AR phase states: H x) [rad]",
    "theta_s": "estimate of the scintillation phase [rad]",
    "rho_s": "estimate of the scintillation amplitude",
    "s4_hat": "on-line S4 estimate (NaN: not estimable in its window)",
    "ar_set": "index of the AR parameter set in use",
    "discriminator": "discriminator output the loop used [rad]",
    "frequency_hz": "carrier Doppler estimate [Hz]",
    "R": "measurement-noise variance of the phase update [rad2]",
    "phi3": "sigma_phi over the last 3 s (SAKF monitor) [rad]",
    "T": "power-law strength of the scintillation phase at 1 Hz (SAKF monitor) [rad2/Hz]",
    "p": "power-law slope of the scintillation phase (SAKF monitor)",
    "weight": "gain weight of eq. (12) of Susi et al. 2014 (SAKF monitor)",
    "amplitude": "estimate of the signal amplitude [prompt units]",
    "p_plus": "posterior probability of the data level d = +1",
    "log_odds": "log-odds of d = +1 against d = -1",
    "cn0_dbhz": "C/N0 estimate [dB-Hz]",
    "cov_fail_epoch": "(trials,): first epoch whose covariance failed its check (-1: none)",
}


@runtime_checkable
class Tracker(Protocol):
    """A carrier tracker type: complex prompts (trials, epochs) in, theta_d estimates out.

    This is the whole contract between a tracker and the pipeline, for the
    built-in types and for plug-ins alike (``docs/adding-a-tracker.md``;
    :func:`scintrack.testing.check_tracker` checks it on a type).

    A tracker class subclasses this protocol and defines

    * ``SCHEMA`` (class attribute): JSON-Schema ``properties`` of the keys its
      config entry may hold besides ``type`` and ``label`` (the registry adds
      those two and refuses any other key, one line naming it);
    * ``TRACKING_KEYS`` (class attribute): every key of the shared ``tracking:``
      section that ``from_spec`` reads, and no other.  An experiment is handed
      only these (:mod:`scintrack.pipeline.params`), so a key read but not
      declared is missing in the workflow, and changing a key not declared
      does not rerun the experiment.  Optional ``SPEC_OVERRIDES``
      ``{spec key: tracking key}``: a spec that sets the key does not read the
      shared value (:func:`.registry.tracking_keys`);
    * ``PROVIDES`` (class attribute): the optional outputs ``run`` can give, names of
      :data:`OUTPUT_NAMES` (the runner reads ``total_phase``, ``theta_s``,
      ``s4_hat``, ``discriminator``, ``frequency_hz`` and the SAKF monitors;
      the others are for tests and figures);
    * :meth:`from_spec`, :meth:`label`, :meth:`run`, and :meth:`reference`
      (required of the package's own trackers, optional for a plug-in: when
      defined, the conformance check compares ``run`` with it).

    It inherits ``design_point``, ``needs_noise_reference`` and
    :meth:`request` as defaults and overrides them where it differs.

    What ``run`` receives: ``y`` complex128 (trials, epochs), C-contiguous,
    the prompt correlator outputs at the context's ``ts`` (amplitude about
    ``tracking.amplitude``, noise per C/N0; pilot signal on the CSM scenarios,
    data bits on the GPS channel); ``init`` the acquisition values per trial
    (:class:`TrackInit`).  It must not modify either.  What it returns: a
    :class:`TrackOutput` whose ``theta_d`` is float (trials, epochs), finite,
    the estimated dynamics phase at each epoch in rad (for a tracker without a
    scintillation model: its carrier phase), and whose ``extras`` are exactly
    the outputs :meth:`request` returned, each (trials, epochs) (``cov_fail_epoch``:
    (trials,)), finite except where :data:`scintrack.experiments.guards.NONFINITE_ALLOWED`
    says.  Trials are independent: trial k's outputs are the same, bit for
    bit, in any batch and position.  A tracker holds settings only, no run
    state: one built tracker runs many batches.
    """

    #: JSON-Schema ``properties`` of the type's spec keys (:mod:`.registry` adds ``type`` and ``label``)
    SCHEMA: ClassVar[Mapping[str, Any]]
    #: the keys of the shared ``tracking:`` settings ``from_spec`` reads, and no others: an experiment is
    #: handed only these (:mod:`scintrack.pipeline.params`), so changing another key does not rerun it
    TRACKING_KEYS: ClassVar[tuple[str, ...]]
    #: every optional output ``run`` can give (names of :data:`OUTPUT_NAMES`)
    PROVIDES: ClassVar[frozenset[str]]

    #: (S4, tau0) of the AR look-up-table point a fixed design was built with; None: adaptive or no scintillation model
    design_point: tuple[float, float] | None = None
    #: ``run`` reads ``TrackInit.noise_reference`` (samples of a signal-free correlator)
    needs_noise_reference: bool = False

    @classmethod
    def from_spec(cls, spec: Mapping[str, Any], context: TrackerContext) -> Tracker:
        """The tracker of the config entry ``spec`` (``config["trackers"][name]``).

        ``spec`` has passed the type's ``SCHEMA``.  Values the spec does not set
        come from ``context`` (:class:`TrackerContext`: ``ts``, ``scenario``,
        ``lut``, ``trace_set`` and only the ``tracking`` keys of
        ``TRACKING_KEYS``).  Raises ValueError for a spec it cannot build (the
        registry adds the tracker's name).  Pure: the same spec and context give
        an equal tracker.
        """
        ...

    @staticmethod
    def label(name: str, spec: Mapping[str, Any]) -> str:
        """Plain-text name of a tracker of ``spec`` in figures and tables: one short line, derived from the spec
        only (``name`` is the config name; a spec's ``label`` key overrides the result, :func:`.registry.label`)."""
        ...

    def run(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """The filter the experiments run: ``theta_d`` (trials, epochs) and the optional outputs of :meth:`request`.

        ``y``: complex prompts (trials, epochs); ``init``: acquisition values per trial.  Trials are
        independent: a trial's outputs do not depend on the others in the batch (class docstring).
        """
        ...

    def reference(self, y: np.ndarray, init: TrackInit) -> TrackOutput:
        """The textbook numpy form of the same filter (the test oracle of :meth:`run`), the same outputs.

        Agrees with :meth:`run` to rounding (:func:`scintrack.testing.check_tracker` compares them);
        one trial-vectorised time loop with the literature's names (F, Q, H, R, P, K).
        """
        ...

    def request(self, wanted: Collection[str]) -> frozenset[str]:
        """Ask ``run`` for the optional outputs ``wanted``; returns the optional outputs ``run`` gives from now on.

        A tracker records an output that costs memory only when it is asked for
        (the AEKF-AR's state estimates); the default gives every output of ``PROVIDES``.
        """
        return self.PROVIDES


@dataclass(frozen=True)
class TrackerContext:
    """What a tracker spec may refer to besides its own keys.

    * ``scenario``: the scenario mapping (``design: scenario`` reads its first
      segment; ``cn0_dbhz`` overrides the nominal C/N0);
    * ``tracking``: the shared ``tracking:`` settings the job was given (Q, P0, windows, ...;
      :meth:`scintrack.settings.TrackingSettings.given`);
    * ``lut``: the AR look-up table (``xarray.Dataset``) or None;
    * ``ts``: the correlator period [s];
    * ``trace_set``: the AR models fitted on a trace
      (:class:`scintrack.models.ar.ScintillationAR`) or None.
    """

    scenario: Mapping[str, Any]
    tracking: Mapping[str, Any]
    ts: float
    lut: Any = None
    trace_set: Any = None

    @property
    def cn0_hz(self) -> float:
        """Nominal C/N0 [Hz] of the scenario (``tracking.cn0_dbhz`` unless the scenario overrides it)."""
        return 10.0 ** (float(self.scenario.get("cn0_dbhz", self.tracking["cn0_dbhz"])) / 10.0)


def dynamics_F(ts: float) -> np.ndarray:
    return np.array([[1.0, 2 * np.pi * ts, np.pi * ts**2], [0.0, 1.0, ts], [0.0, 0.0, 1.0]])


def dynamics_Q(q_jerk: float, ts: float) -> np.ndarray:
    t = ts
    c = 2 * np.pi
    return q_jerk * np.array(
        [
            [c * c * t**5 / 20, c * t**4 / 8, c * t**3 / 6],
            [c * t**4 / 8, t**3 / 3, t**2 / 2],
            [c * t**3 / 6, t**2 / 2, t],
        ]
    )


def atan2_discriminator(y: np.ndarray, phase: np.ndarray) -> np.ndarray:
    """Four-quadrant phase error of ``y`` against the replica phase, in (-pi, pi]
    (:func:`.blocks.atan2_discriminator` on arrays)."""
    y = np.asarray(y)
    return blocks.atan2_discriminator_ufunc(y.real, y.imag, phase)


def atan_variance(cn0_hz: np.ndarray | float, ts: float) -> np.ndarray:
    """Discriminator noise variance, eq. (12) of Vila-Valls 2018, evaluated at x = 2 C/N0 Ts.

    ``sigma^2 = (exp(-0.8 sqrt(x)) + 1) erf(0.4 x) / x``.  The paper writes
    the argument as C/N0 Ts; with that argument the formula tends to
    ``1/(C/N0 Ts)`` at high C/N0, twice the known high-SNR variance
    ``1/(2 C/N0 Ts)``.  With ``x = 2 C/N0 Ts`` it tends to the right limit and
    follows the Monte Carlo variance of the discriminator within about 5% from
    10 to 35 dB-Hz (reference notes §3.2; ``tests/test_trackers.py`` checks it).
    The formula is :func:`.blocks.atan_variance`; this is its array form.
    """
    return blocks.atan_variance_ufunc(np.asarray(cn0_hz, dtype=float), float(ts))


def companion(coefs: np.ndarray, size: int) -> np.ndarray:
    """AR companion block ``[[a1 .. a_size], [1 0 ..], ...]``, coefficients zero-padded."""
    out = np.zeros((size, size))
    out[0, : len(coefs)] = coefs
    out[np.arange(1, size), np.arange(size - 1)] = 1.0
    return out


def initial_state(init: TrackInit, n_state: int) -> np.ndarray:
    """State (trials, n_state) with the dynamics block from the acquisition, the rest 0."""
    x = np.zeros((np.asarray(init.phase).size, n_state))
    x[:, 0], x[:, 1], x[:, 2] = init.phase, init.doppler_hz, init.rate_hz_s
    return x


def spec_q_jerk(spec: Mapping[str, Any], context: TrackerContext) -> float:
    """The Doppler-jerk PSD: the spec's ``q_jerk_hz2_s3`` or the shared one."""
    return float(spec["q_jerk_hz2_s3"] if "q_jerk_hz2_s3" in spec else context.tracking["q_jerk_hz2_s3"])


def spec_p0(context: TrackerContext) -> tuple[float, float, float]:
    return tuple(float(v) for v in context.tracking["p0_diag"])


#: JSON-Schema fragments shared by several tracker types (one place each).
Q_JERK_SCHEMA = {"type": "number", "minimum": 0, "description": "PSD of the Doppler jerk in Q_d [Hz2/s3] (default: tracking.q_jerk_hz2_s3)"}
DESIGN_SCHEMA = {
    "description": "AR parameters: scenario (look-up-table point of the scenario's first segment), none (SSM #1), trace (fitted on the trace) or {s4, tau0}",
    "oneOf": [
        {"enum": ["scenario", "none", "trace"]},
        {
            "type": "object",
            "additionalProperties": False,
            "required": ["s4", "tau0"],
            "properties": {
                "s4": {"type": "number", "exclusiveMinimum": 0, "maximum": 1.5},
                "tau0": {"type": "number", "exclusiveMinimum": 0, "maximum": 100},
            },
        },
    ],
}
PHASE_ORDER_SCHEMA = {"type": "integer", "minimum": 1, "maximum": 3, "description": "AR(p) phase order (default: Table I of the region)"}
