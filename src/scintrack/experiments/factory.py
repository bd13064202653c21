"""Build trackers from their config entries (a tracker is a config line).

Tracker specs (``config["trackers"]``)::

    pll:      {type: pll}
    kf:       {type: kf}
    akf:      {type: akf}
    akf_ar:   {type: akf_ar, design: scenario}
    aekf_ar:  {type: aekf_ar, adaptive: true}
    aekf_ar13:{type: aekf_ar, design: scenario, phase_order: 1, state: [1, 3]}
    mism_0.9: {type: aekf_ar, design: {s4: 0.9, tau0: 0.1}}

``design`` says which AR parameters a non-adaptive filter uses: ``scenario``
(the look-up-table point of the scenario's first segment), ``none`` (no
scintillation model: SSM #1 of Case I), ``trace`` (the AR models fitted on
the first part of a real or surrogate trace, Sec. VI-E) or an explicit
``{s4, tau0}``.  ``static: true`` fixes the dynamics block at zero (known,
no process noise): the dynamics-free scintillation tracking of Sec. VI-E2.  The
AR orders follow Table I of Vila-Valls 2018 (q = 3; p = 1/2/3 for the
severe/moderate/low region) unless ``phase_order`` is given.  The shared loop
settings (Q, P0, bandwidth, windows) come from ``config["tracking"]``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from ..models.lut import lookup
from ..models.regions import region_of
from ..trackers.aekf_ar import AEKFAR, ArSet
from ..trackers.kf import DiscriminatorKF
from ..trackers.pll import PLL

TABLE_I_PHASE_ORDER = {"severe": 1, "moderate": 2, "low": 3}
AMPLITUDE_ORDER = 3


def ar_set(lut: xr.Dataset, s4: float, tau0: float, phase_order: int | None = None) -> ArSet:
    """AR parameters of the look-up-table point nearest to (s4, tau0)."""
    p = phase_order or TABLE_I_PHASE_ORDER[region_of(s4)]
    ph = lookup(lut, s4, tau0, "phase", p)
    am = lookup(lut, s4, tau0, "amplitude", AMPLITUDE_ORDER)
    return ArSet(beta=ph.coefs, gamma=am.coefs, kappa=am.const, sigma2_theta=ph.sigma2, sigma2_rho=am.sigma2, s4=ph.s4, label=f"S4={ph.s4:g},tau0={ph.tau0:g},AR({p})/AR(3)")


def design_set(spec: Mapping[str, Any], scenario: Mapping[str, Any], lut: xr.Dataset, trace_set: ArSet | None = None) -> ArSet:
    design = spec.get("design", "scenario")
    if design == "none":
        return ArSet.no_scintillation()
    if design == "trace":
        if trace_set is None:
            raise ValueError("a tracker with design: trace runs only on trace scenarios (real_traces)")
        return trace_set
    if design == "scenario":
        segs = scenario.get("segments", [])
        if not segs:
            return ArSet.no_scintillation()
        design = segs[0]
    return ar_set(lut, float(design["s4"]), float(design["tau0"]), spec.get("phase_order"))


def build(name: str, spec: Mapping[str, Any], scenario: Mapping[str, Any], tracking: Mapping[str, Any], lut: xr.Dataset, ts: float, trace_set: ArSet | None = None):
    kind = spec["type"]
    cn0 = 10.0 ** (float(scenario.get("cn0_dbhz", tracking["cn0_dbhz"])) / 10.0)
    amp = float(tracking["amplitude"])
    q = float(spec.get("q_jerk_hz2_s3", tracking["q_jerk_hz2_s3"]))
    p0 = tuple(float(v) for v in tracking["p0_diag"])
    if spec.get("static", False):
        if kind != "aekf_ar":
            raise ValueError(f"tracker {name!r}: static: true is only defined for the aekf_ar type")
        q, p0 = 0.0, (0.0, 0.0, 0.0)
    if kind == "pll":
        return PLL(ts=ts, bandwidth_hz=float(spec.get("bandwidth_hz", tracking["pll_bandwidth_hz"])))
    if kind in ("kf", "akf", "akf_ar"):
        kw = dict(ts=ts, q_jerk=q, nominal_cn0_hz=cn0, p0_diag=p0, adaptive_r=kind != "kf", cn0_window=int(tracking["cn0_window"]), amplitude=amp)
        if kind == "akf_ar":
            s = design_set(spec, scenario, lut, trace_set)
            kw.update(ar_coefs=s.beta, ar_sigma2=s.sigma2_theta, ar_p0=float(tracking["theta_s_p0"]))
        return DiscriminatorKF(**kw)
    if kind == "aekf_ar":
        p_state, q_state = spec.get("state", [3, 3])
        adaptive = bool(spec.get("adaptive", False))
        if adaptive:
            sets = [ArSet.no_scintillation()] + [ar_set(lut, float(s4), float(tau0)) for s4, tau0 in tracking["adaptation_points"]]
            initial = 0
        else:
            sets = [design_set(spec, scenario, lut, trace_set)]
            initial = 0
        return AEKFAR(
            ts=ts, q_jerk=q, p0_diag=p0, ar_sets=sets, p_state=int(p_state), q_state=int(q_state), adaptive=adaptive,
            initial_set=initial, amplitude=amp, nominal_noise=amp**2 / (cn0 * ts),
            noise_window=int(tracking["noise_window"]), s4_window=int(tracking["s4_window"]),
            s4_min_epochs=int(tracking["s4_min_epochs"]), adapt_hold=int(tracking["adapt_hold"]),
            theta_s_p0=float(tracking["theta_s_p0"]), rho_p0=float(tracking["rho_p0"]),
            fold_mirror=bool(spec.get("fold_mirror", False)),
        )
    raise ValueError(f"tracker {name!r}: unknown type {kind!r} (pll, kf, akf, akf_ar, aekf_ar)")


def acquisition(real, tracking: Mapping[str, Any], static: bool = False):
    """Initial values every tracker gets: phase of the first prompt, nominal Doppler, zero rate.

    ``static``: the dynamics are known to be zero (phase, Doppler and rate 0).
    """
    from ..trackers.base import TrackInit

    n = real.y.shape[0]
    if static:
        return TrackInit(phase=np.zeros(n), doppler_hz=np.zeros(n), rate_hz_s=np.zeros(n))
    return TrackInit(
        phase=np.angle(real.y[:, 0]),
        doppler_hz=np.full(n, float(tracking["fd0_hz"])),
        rate_hz_s=np.zeros(n),
    )
