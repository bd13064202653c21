"""Config values outside a model's validity are refused before anything runs.

:func:`check_model_ranges` (called at the end of
:func:`scintrack.config.check_consistency`) raises a one-line
:class:`~scintrack.errors.ConfigError` naming the key and the fix for:

* **S4 the CSM cannot realise.**  The CSM's Nakagami/Rician match
  ``m = max(1, 1/S4^2)`` makes every S4 >= 1 the S4 = 1 (Rayleigh) field, so
  an S4 above :data:`scintrack.signals.csm.S4_MAX` (1) would be generated as
  about 1 (S4 = 1.5 realised 0.97) while the results record the request.
  Every (S4, tau0) of the CSM and of its AR table goes through the schema's
  ``$defs/s4`` (maximum 1: scenario segments, ``ar_training.s4``,
  ``tracking.adaptation_points``, ``figures...ar_cases``); this module checks
  the ones the schema cannot reach: a tracker's explicit ``design: {s4,
  tau0}`` (its schema fragment is the tracker type's) and a scenario's own
  ``tracking.adaptation_points`` (a free-form override).  The phase-screen
  surrogates (``real_traces.surrogate.events.*.s4_l1``,
  ``susi_2014.traces.*.surrogate.s4_l1``) have their own schema maximum, 1,
  and their calibration refuses an S4 it cannot reach (saturation near 1).
* **Look-ups off the AR grid.**  A ``scintillation_model: ar`` scenario, a
  tracker's ``design`` (explicit, or ``scenario``: the first segment of every
  scenario it runs on in an experiment, a time-varying profile included),
  ``tracking.adaptation_points`` (shared or a scenario's own) and
  ``floors.scenarios`` take the models of the nearest ``ar_training`` grid
  point (:func:`scintrack.models.lut.nearest_point`, the one rule).  A request
  further than the look-up tolerance (:func:`scintrack.models.lut.within_tolerance`:
  0.005 in S4, 1 % in tau0) would silently use another model (S4 = 1.5 used
  the S4 = 1 models and realised 0.77), so it is refused with the requested
  and the nearest point and the fix (add the point to ``ar_training.s4/tau0``
  or change the request).  Within the tolerance the grid point is used and
  recorded (a tracker's ``design_point``, a scenario's ``model_point`` and
  ``s4_t``/``tau0_t``).  The default ``config/config.yaml`` and its
  ``config/smoke.yaml`` overlay ask only for grid points.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from typing import Any

from .errors import ConfigError
from .models.lut import LOOKUP_TOL_S4, LOOKUP_TOL_TAU0, grid_of, nearest_point, within_tolerance
from .signals.csm import S4_MAX


def check_model_ranges(config: Mapping[str, Any], source: str = "config/config.yaml") -> None:
    """Refuse S4 values the CSM does not realise and AR look-ups off the ``ar_training`` grid (module docstring)."""
    requests = list(_lookups(config))
    segments = [(f"scenarios.{name}.segments[{i}]", f"segment {i} of scenario {name!r}", _point(seg), "")
                for name, sc in config["scenarios"].items() if sc.get("scintillation_model", "csm") in ("csm", "ar")
                for i, seg in enumerate(sc.get("segments", []))]
    for key, what, (s4, tau0), _fix in segments + requests:
        if not 0.0 < s4 <= S4_MAX:  # also NaN, which the schema's bounds let through
            problem = f"is above {S4_MAX:g}" if s4 > S4_MAX else f"is not in 0 < S4 <= {S4_MAX:g}"
            raise ConfigError(
                f"invalid config value at '{key}': S4 {s4:g} ({what}) {problem}, the largest S4 the CSM generator "
                f"realises (Nakagami/Rician m >= 1); use 0 < S4 <= {S4_MAX:g} in {source}"
            )
        if not 0.0 < tau0 < math.inf:
            raise ConfigError(f"invalid config value at '{key}': tau0 {tau0:g} ({what}) is not a decorrelation time > 0; fix it in {source}")
    grid = grid_of(config["ar_training"]["s4"], config["ar_training"]["tau0"])
    for key, what, point, fix in requests:
        used = nearest_point(grid, *point)
        if not within_tolerance(point, used):
            raise ConfigError(
                f"invalid config value at '{key}': {what} (S4={point[0]:g}, tau0={point[1]:g}) is not on the ar_training grid "
                f"(nearest point S4={used[0]:g}, tau0={used[1]:g}; tolerance {LOOKUP_TOL_S4:g} in S4, {100 * LOOKUP_TOL_TAU0:g} % in tau0); "
                f"add the point to ar_training.s4/tau0 or {fix} in {source}"
            )


def _point(entry: Any) -> tuple[float, float]:
    if isinstance(entry, Mapping):
        return float(entry["s4"]), float(entry["tau0"])
    return float(entry[0]), float(entry[1])


def _lookups(config: Mapping[str, Any]) -> Iterator[tuple[str, str, tuple[float, float], str]]:
    """Every (key, what, (S4, tau0), fix) the pipeline looks up in the AR table."""
    from .trackers.design import design_request
    from .trackers.registry import get

    scenarios = config["scenarios"]
    for i, p in enumerate(config["tracking"]["adaptation_points"]):
        yield f"tracking.adaptation_points[{i}]", "the adaptation point", _point(p), "change the point"
    for name, sc in scenarios.items():
        for i, p in enumerate(dict(sc.get("tracking", {})).get("adaptation_points", [])):
            yield f"scenarios.{name}.tracking.adaptation_points[{i}]", "the adaptation point", _point(p), "change the point"
        if sc.get("scintillation_model") == "ar" and sc.get("segments"):
            yield f"scenarios.{name}.segments[0]", f"the AR scintillation of scenario {name!r}", _point(sc["segments"][0]), "change the scenario"
    for name in config.get("floors", {}).get("scenarios", []):
        segs = scenarios.get(name, {}).get("segments", [])
        if segs:
            yield f"scenarios.{name}.segments[0]", f"the AR(1) floor of scenario {name!r} (floors.scenarios)", _point(segs[0]), "change the scenario"
    uses_design = {}
    for name, spec in config["trackers"].items():
        uses_design[name] = "design" in get(spec["type"]).schema and not spec.get("adaptive", False)
        if uses_design[name] and isinstance(spec.get("design"), Mapping):
            yield f"trackers.{name}.design", f"the design of tracker {name!r}", _point(spec["design"]), "change the design"
    for exp_name, exp in config["experiments"].items():
        for tr in exp["trackers"]:
            spec = config["trackers"].get(tr)
            if spec is None or not uses_design.get(tr) or spec.get("design", "scenario") != "scenario":
                continue
            for sc in exp["scenarios"]:
                request = design_request(spec, scenarios.get(sc))
                if isinstance(request, tuple):
                    yield (f"scenarios.{sc}.segments[0]", f"design: scenario of tracker {tr!r} in experiment {exp_name!r}", request,
                           f"change scenario {sc!r} or the tracker's design")
