"""Which AR models a non-adaptive AR tracker uses (the ``design`` spec key) and
the label pieces derived from it; shared by the AKF-AR and the AEKF-AR.

``design``: ``scenario`` (default; the look-up-table point of the scenario's
first segment, no scintillation model on a scenario without segments),
``none`` (no scintillation model: SSM #1 of Case I), ``trace`` (the AR models
fitted on the first part of a real or surrogate trace, Sec. VI-E) or an
explicit ``{s4, tau0}``.  AR orders follow Table I of Vila-Valls 2018 (q = 3;
p = 1/2/3 for the severe/moderate/low region) unless ``phase_order`` is given.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..models.ar import ScintillationAR
from ..models.lut import scintillation_ar
from .base import TrackerContext


def design_ar(spec: Mapping[str, Any], context: TrackerContext) -> ScintillationAR:
    design = spec.get("design", "scenario")
    if design == "none":
        return ScintillationAR.no_scintillation()
    if design == "trace":
        if context.trace_set is None:
            raise ValueError("a tracker with design: trace runs only on trace scenarios (real_traces)")
        return context.trace_set
    if design == "scenario":
        segs = context.scenario.get("segments", [])
        if not segs:
            return ScintillationAR.no_scintillation()
        design = segs[0]
    if context.lut is None:
        raise ValueError("design from the AR look-up table, but no table was given")
    return scintillation_ar(context.lut, float(design["s4"]), float(design["tau0"]), spec.get("phase_order"))


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
