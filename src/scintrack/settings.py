"""The ``tracking:`` settings a job reads, as one typed, frozen object.

A job gets the settings it depends on as a plain mapping (its rule's params,
:mod:`scintrack.pipeline.params`); :meth:`TrackingSettings.from_params` turns
that mapping into attributes with the types of the config schema.  The
defaults of the optional keys live in the schema only
(``workflow/schemas/config.schema.yaml``, ``tracking``): Snakemake's
``validate`` writes them into the config, and the params take the values from
there, so no value is repeated here.

A job is handed only the keys it depends on (a change of
``tracking.pll_bandwidth_hz`` reruns only the experiments with a PLL), so a
field is None when the job was not given that key; each job names the keys it
requires (:data:`EXPERIMENT_KEYS` for the tracking experiments) and gets one
clear error naming a missing or unknown key.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, fields
from typing import Any

from .errors import ConfigError


def _floats(value: Any) -> tuple[float, ...]:
    return tuple(float(v) for v in value)


def _points(value: Any) -> tuple[tuple[float, ...], ...]:
    return tuple(_floats(p) for p in value)


@dataclass(frozen=True)
class TrackingSettings:
    """Every key of the config's ``tracking:`` section (None: not given to this job)."""

    # the signal every scenario simulates (its own cn0_dbhz, fd0_hz, fr_hz_s win)
    cn0_dbhz: float | None  # nominal C/N0 [dB-Hz]
    amplitude: float | None  # correlator amplitude A
    fd0_hz: float | None  # initial Doppler [Hz]
    fr_hz_s: float | None  # Doppler rate [Hz/s]
    # the metrics of the runner
    steady_state_start_s: float | None  # start of the steady-state window [s]
    slip_hysteresis_rad: float | None  # a cycle slip when |e - 2 pi n| >= pi + this [rad]
    slip_settle_s: float | None  # a slip event ends after the error stays this long in one cell [s]
    stats_resolution_s: float | None  # block of the per-epoch statistics [s]
    jitter_window_s: float | None  # window of the phase jitter [s]
    lock_window_s: float | None  # block of the phase lock detector [s]
    lock_threshold: float | None  # in lock when the cos(2 dphi) estimate >= this
    # read by the trackers (their TRACKING_KEYS) through TrackerContext
    pll_bandwidth_hz: float | None
    q_jerk_hz2_s3: float | None
    p0_diag: tuple[float, ...] | None
    theta_s_p0: float | None
    rho_p0: float | None
    cn0_window: int | None
    noise_window: int | None
    s4_window: int | None
    s4_min_epochs: int | None
    adapt_hold: int | None
    adaptation_points: tuple[tuple[float, ...], ...] | None

    @classmethod
    def from_params(cls, values: Mapping[str, Any], require: Iterable[str] = ()) -> TrackingSettings:
        """The settings of ``values`` (a job's ``tracking`` params, scenario overrides applied).

        Raises :class:`~scintrack.errors.ConfigError` naming the first key that is
        not a tracking setting, or the first of ``require`` that is missing.
        """
        unknown = sorted(set(values) - set(_CONVERT))
        if unknown:
            raise ConfigError(f"tracking.{unknown[0]}: not a tracking setting (known: {', '.join(sorted(_CONVERT))})")
        missing = [key for key in require if key not in values]
        if missing:
            raise ConfigError(f"tracking.{missing[0]}: missing from the tracking settings this job was given (its rule's params)")
        return cls(**{key: convert(values[key]) if key in values else None for key, convert in _CONVERT.items()})

    def given(self) -> dict[str, Any]:
        """The keys this job was given, typed: what :class:`~scintrack.trackers.base.TrackerContext` hands the trackers."""
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) is not None}


_TYPES = {"float | None": float, "int | None": int, "tuple[float, ...] | None": _floats, "tuple[tuple[float, ...], ...] | None": _points}
#: key -> the conversion of its value (from the field's type)
_CONVERT = {f.name: _TYPES[f.type] for f in fields(TrackingSettings)}

#: the keys every tracking experiment reads (the signal and the metrics), whatever its trackers
EXPERIMENT_KEYS = (
    "cn0_dbhz", "amplitude", "fd0_hz", "fr_hz_s", "steady_state_start_s", "slip_hysteresis_rad", "slip_settle_s", "stats_resolution_s", "jitter_window_s",
    "lock_window_s", "lock_threshold",
)
#: the keys the achievability floors read (:mod:`.floors`)
FLOORS_KEYS = ("cn0_dbhz", "amplitude", "q_jerk_hz2_s3", "p0_diag", "theta_s_p0", "rho_p0", "steady_state_start_s")
