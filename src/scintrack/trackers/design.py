"""Which AR models a non-adaptive AR tracker uses (the ``design`` spec key) and
the label pieces derived from it; shared by the AKF-AR and the AEKF-AR.

``design``: ``scenario`` (default; the look-up-table point of the scenario's
first segment, no scintillation model on a scenario without segments),
``none`` (no scintillation model: SSM #1 of Case I), ``trace`` (the AR models
fitted on the first part of a real or surrogate trace, Sec. VI-E) or an
explicit ``{s4, tau0}``.  AR orders follow Table I of Vila-Valls 2018 (q = 3;
p = 1/2/3 for the severe/moderate/low region) unless ``phase_order`` is given.

The (S4, tau0) a design asks for (:func:`design_request`) becomes the
nearest grid point of the table (:func:`scintrack.models.lut.nearest_point`);
:mod:`scintrack.validity` refuses, at config time, a request further from
the grid than the look-up tolerance (:func:`scintrack.models.lut.within_tolerance`),
so within it the point actually used may differ from the request by rounding
only.  A built tracker exposes that point as ``design_point`` (S4, tau0)
(:func:`design_point`: None for no scintillation model or an adaptive
tracker; the trace fit's S4 and tau0 = NaN for ``design: trace``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..models.ar import ScintillationAR
from ..models.lut import scintillation_ar
from .base import TrackerContext


def design_request(spec: Mapping[str, Any], scenario: Mapping[str, Any] | None) -> tuple[float, float] | str:
    """What the ``design`` of ``spec`` asks for on ``scenario``: the (S4, tau0) to look up, or ``"none"`` / ``"trace"``.

    ``design: scenario`` asks for the first segment of the scenario (a
    time-varying profile: its first piece), ``"none"`` on a scenario without
    segments.
    """
    design = spec.get("design", "scenario")
    if design in ("none", "trace"):
        return design
    if design == "scenario":
        segs = (scenario or {}).get("segments", [])
        if not segs:
            return "none"
        design = segs[0]
    return float(design["s4"]), float(design["tau0"])


def design_ar(spec: Mapping[str, Any], context: TrackerContext) -> ScintillationAR:
    design = design_request(spec, context.scenario)
    if design == "none":
        return ScintillationAR.no_scintillation()
    if design == "trace":
        if context.trace_set is None:
            raise ValueError("a tracker with design: trace runs only on trace scenarios (real_traces)")
        return context.trace_set
    if context.lut is None:
        raise ValueError("design from the AR look-up table, but no table was given")
    return scintillation_ar(context.lut, design[0], design[1], spec.get("phase_order"))


def design_point(ar: ScintillationAR) -> tuple[float, float] | None:
    """(S4, tau0) of the models ``ar`` actually are (the grid point used), None for no scintillation model."""
    if ar.label == "none":
        return None
    return float(ar.s4), float(ar.tau0)


def explicit_design_s4(spec: Mapping[str, Any]) -> float | None:
    """S4 of an explicit ``design: {s4, tau0}``, else None."""
    design = spec.get("design")
    return float(design["s4"]) if isinstance(design, Mapping) else None


def q_qualifier(spec: Mapping[str, Any]) -> list[str]:
    """``["q = <value>"]`` when the spec sets its own Doppler-jerk PSD."""
    return [f"q = {float(spec['q_jerk_hz2_s3']):g}"] if "q_jerk_hz2_s3" in spec else []


def compose(base: str, qualifiers: list[str], suffix: str = "") -> str:
    """``base (q1, q2)suffix``."""
    return base + (f" ({', '.join(qualifiers)})" if qualifiers else "") + suffix
