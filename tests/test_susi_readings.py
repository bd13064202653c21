"""Susi et al. 2014, readings U1-U4 of eqs. (7)-(8): the units relation, each reading's formula, the loops and the verdict."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, signal

from scintrack.experiments.susi_readings import readings_loops
from scintrack.trackers import registry
from scintrack.trackers.base import TrackerContext
from scintrack.trackers.susi_kf import (
    SCINTILLATION_Q_READINGS,
    increment_variance,
    loop_bandwidth_hz,
    scintillation_q_psd,
    steady_state_gain,
)

TS = 0.001
F_IRR = 0.19
TRACKING = {"amplitude": 1.0, "cn0_dbhz": 45.0, "p0_diag": [0.25, 1.0, 100.0], "q_jerk_hz2_s3": 0.01}


def _context(clock="ocxo", cn0=45.0):
    return TrackerContext(scenario={"clock": clock, "cn0_dbhz": cn0}, tracking=TRACKING, ts=TS)


def _sakf(reading=None):
    spec = {"type": "susi_sakf", "discriminator": "atan2"}
    if reading is not None:
        spec["scintillation_q_reading"] = reading
    return registry.build("s", spec, _context())


def test_frequency_psd_is_nu_squared_times_phase_psd():
    """phi(t) in rad, f = (dphi/dt) / (2 pi) in Hz: the Welch PSDs satisfy S_f(nu) = nu^2 S_phi(nu) (not (2 pi nu)^2 S_phi)
    on a simulated power-law phase (T (nu^2 + nu_c^2)^(-p/2), a corner that keeps the Welch leakage negligible)."""
    rng = np.random.default_rng(7)
    n, nper = 2**19, 8192
    nu = np.fft.rfftfreq(n, TS)
    shape = np.sqrt(1e-2 * (nu**2 + 1.0) ** (-1.25) / (2 * TS))
    phi = np.fft.irfft(np.fft.rfft(rng.standard_normal(n)) * shape, n)
    freq = np.diff(phi) / (2 * math.pi * TS)  # the backward difference: its gain is |2 sin(pi nu ts)| / ts, 1 - 3e-4 at 10 Hz
    f1, s_phi = signal.welch(phi, fs=1 / TS, nperseg=nper)
    f2, s_f = signal.welch(freq, fs=1 / TS, nperseg=nper)
    for target in (0.5, 1.0, 2.0, 5.0, 10.0, 20.0):
        band = (f1 > target * 0.9) & (f1 < target * 1.1)  # a few bins: the ratio of two estimates of the same realisation
        ratio = np.mean(s_f[band]) / np.mean(f1[band] ** 2 * s_phi[band])
        assert abs(ratio - 1) < 0.03, (target, ratio)
    assert np.array_equal(f1, f2)


def test_eq8_term_of_the_tracker_has_no_two_pi():
    """The default SAKF (reading ``literal``): S_dphi = T f_irr^-p and S_df = f_irr^2 T f_irr^-p, exactly; the declared U1
    (``literal_cycles``) divides the latter by (2 pi)^2."""
    T, p = np.array([1e-2, 0.021, 3.8]), np.array([2.5, 4.05, 2.56])
    s_phi, s_f = _sakf().scint_psd(T, p)
    np.testing.assert_allclose(s_phi, T * F_IRR**-p, rtol=1e-14)
    np.testing.assert_allclose(s_f, F_IRR**2 * T * F_IRR**-p, rtol=1e-14)
    c_phi, c_f = _sakf("literal_cycles").scint_psd(T, p)
    np.testing.assert_allclose(c_phi, s_phi, rtol=1e-14)
    np.testing.assert_allclose(c_f, s_f / (2 * math.pi) ** 2, rtol=1e-14)
    u2 = _sakf("eq8_only").scint_psd(T, p)
    assert np.all(u2[0] == 0) and np.allclose(u2[1], s_f, rtol=1e-14)
    u3 = _sakf("freq_random_walk").scint_psd(T, p)
    assert np.all(u3[0] == 0)
    # U3: the one-sided phase PSD of the frequency random walk, 2 S_df / ((2 pi)^2 f^4), is T f^-p at f_irr
    np.testing.assert_allclose(2 * u3[1] / ((2 * math.pi) ** 2 * F_IRR**4), T * F_IRR**-p, rtol=1e-13)
    u4 = _sakf("increment_variance").scint_psd(T, p)
    assert np.all(u4[1] == 0)
    np.testing.assert_allclose(u4[0] * TS, increment_variance(T, p, F_IRR, TS), rtol=1e-14)
    for reading in SCINTILLATION_Q_READINGS:  # missing estimates (before the first window) add nothing
        a, b = scintillation_q_psd(reading, np.array([np.nan, 1e-2]), np.array([2.0, np.nan]), F_IRR, TS)
        assert np.all(a == 0) and np.all(b == 0)
    with pytest.raises(ValueError, match="scintillation_q_reading 'cycles' is not one of literal"):
        scintillation_q_psd("cycles", T, p, F_IRR, TS)


def test_frequency_random_walk_has_the_one_sided_psd_u3_assumes():
    """A frequency random walk of intensity S_df (increments of variance S_df ts, as the tracker's Q) has the one-sided
    Welch PSD 2 S_df / (2 pi nu)^2 (the convention of T, :mod:`scintrack.estimators.power_law`), so with S_f = nu^2 S_phi
    its phase PSD is 2 S_df / ((2 pi)^2 nu^4)."""
    rng = np.random.default_rng(3)
    s_df = 0.5
    freq = np.cumsum(rng.normal(0.0, math.sqrt(s_df * TS), (8, 2**17)), axis=1)
    nu, s = signal.welch(freq, fs=1 / TS, nperseg=8192, detrend="linear")
    s = s.mean(axis=0)
    for target in (1.0, 3.0, 10.0):
        band = (nu > target * 0.9) & (nu < target * 1.1)
        ratio = np.mean(s[band] * (2 * math.pi * nu[band]) ** 2 / 2) / s_df
        assert abs(ratio - 1) < 0.05, (target, ratio)


@pytest.mark.parametrize(("T", "p"), [(1e-2, 2.5), (0.021, 4.05), (3.8, 2.56), (1.0, 0.0), (0.5, 1.0)])
def test_increment_variance_is_the_integral(T, p):
    """U4's V = int_{f_irr}^{500 Hz} T f^-p 4 sin^2(pi f ts) df: the Gauss-Legendre rule against adaptive quadrature, and
    against the closed form for p = 0 (T (2 f - sin(2 pi f ts) / (pi ts)) between the limits)."""
    fn = 0.5 / TS
    ref, _ = integrate.quad(lambda f: T * f**-p * 4 * math.sin(math.pi * f * TS) ** 2, F_IRR, fn, limit=500, epsabs=0, epsrel=1e-11)
    got = float(increment_variance(np.array([T]), np.array([p]), F_IRR, TS)[0])
    assert got == pytest.approx(ref, rel=1e-8)
    if p == 0:
        prim = lambda f: T * (2 * f - math.sin(2 * math.pi * f * TS) / (math.pi * TS))  # noqa: E731
        assert got == pytest.approx(prim(fn) - prim(F_IRR), rel=1e-10)


def test_loop_of_each_reading_and_the_loops_file():
    """The Riccati gain with a reading's PSDs: wider than the clock-only AKF for every reading, the declared U1 narrower than
    the rad-consistent one (less frequency noise), a larger T widens it; readings_loops (with the params of the rule,
    pipeline.params.susi_readings_loops) gives the same numbers from a result's per-block medians over the steady-state
    blocks, and w K at the median weight."""
    import xarray as xr

    from scintrack.config import load_config
    from scintrack.pipeline import params as P

    n = 20_000  # 20 s of impulse response: these loops (>= 4 Hz) have decayed to nothing
    T, p = 0.021, 4.05
    akf = registry.build("a", {"type": "susi_akf", "discriminator": "atan2"}, _context())
    b_akf = loop_bandwidth_hz(steady_state_gain(akf), TS, n=n)
    bw = {}
    for reading in SCINTILLATION_Q_READINGS:
        trk = _sakf(reading)
        s_phi, s_f = (float(v[0]) for v in trk.scint_psd(np.array([T]), np.array([p])))
        bw[reading] = loop_bandwidth_hz(steady_state_gain(trk, scint=(s_phi, s_f)), TS, n=n)
        assert bw[reading] > b_akf, (reading, bw[reading], b_akf)
    assert bw["literal_cycles"] < bw["literal"]
    trk = _sakf()
    wider = loop_bandwidth_hz(steady_state_gain(trk, scint=tuple(float(v[0]) for v in trk.scint_psd(np.array([10 * T]), np.array([p])))), TS, n=n)
    assert wider > bw["literal"]

    config = load_config([Path(__file__).resolve().parents[1] / "config" / "config.yaml"])
    run = P.susi_readings_loops(config)
    names = ["susi_akf", "susi_sakf_u1"]
    assert set(names) <= set(run["trackers"]) and "susi_pll" not in run["trackers"]
    run = {**run, "trackers": {k: run["trackers"][k] for k in names}, "scenarios": {"susi_high_latitude": run["scenarios"]["susi_high_latitude"]}}
    n_time = 40
    time = (np.arange(n_time) + 0.5) * 1.0
    steady = time >= 20.0
    T_series = np.where(steady, T, 50.0) * np.ones((2, n_time))  # the transient's values must not count
    T_series[:, steady] *= np.linspace(0.5, 1.5, int(steady.sum()))  # median over the steady blocks = T
    res = xr.Dataset({"T_mean": (("tracker", "time"), T_series), "p_mean": (("tracker", "time"), np.full((2, n_time), p)),
                      "weight_mean": (("tracker", "time"), np.full((2, n_time), 0.6))},
                     coords={"tracker": names, "time": time}, attrs={"steady_state_start_s": 20.0})
    out = readings_loops(run, {"susi_high_latitude": res}, n=n)
    assert list(out["reading"].values) == ["none", "literal_cycles"]
    row = out.sel(scenario="susi_high_latitude", tracker="susi_sakf_u1")
    assert float(row["T_median"]) == pytest.approx(T, rel=1e-12) and float(row["p_median"]) == p
    assert float(row["bandwidth_hz"]) == pytest.approx(bw["literal_cycles"], rel=1e-6)  # OCXO, 45 dB-Hz: the same loop as _context()
    K = steady_state_gain(_sakf("literal_cycles"), scint=(float(row["s_phi"]), float(row["s_f"])))
    assert float(row["bandwidth_weighted_hz"]) == pytest.approx(loop_bandwidth_hz(0.6 * K, TS, n=n), rel=1e-6)
    assert float(out["bandwidth_hz"].sel(scenario="susi_high_latitude", tracker="susi_akf")) == pytest.approx(b_akf, rel=1e-6)


def test_reading_verdict_follows_the_declared_criterion():
    from scintrack.products.tables.susi_2014_readings import reading_verdict

    assert reading_verdict(["holds", "holds"], ["does not hold", "does not hold"]) == "explains"
    assert reading_verdict(["holds", "does not hold"], ["does not hold", "does not hold"]) == "explains part"
    assert reading_verdict(["inconclusive", "does not hold"], ["holds", "holds"]) == "explains part"
    assert reading_verdict(["does not hold", "does not hold"], ["holds", "does not hold"]) == "does not explain"
    assert reading_verdict(["holds"], ["holds"]) == "explains part"  # one scenario cannot explain "both scenarios"
    assert reading_verdict(["holds", "not evaluated: no interval"], ["holds", "holds"]) == "not evaluated"


def test_readings_table_computes_the_verdict_from_paired_intervals():
    """susi_table_readings on constructed results: U1 below the PLL and the AKF in both scenarios (explains), U2 in one
    (explains part), and the loops' bandwidth reaches its row."""
    import xarray as xr
    from test_susi_products import result

    from scintrack.products.tables.susi_2014_readings import susi_table_readings

    rng = np.random.default_rng(5)
    names = ["susi_pll", "susi_akf", "susi_sakf_u1", "susi_sakf_u2"]

    def jit(level):
        return level + 0.005 * rng.standard_normal((4, 3))

    res = [result("susi_readings", "susi_high_latitude", names, jitter=dict(zip(names, map(jit, (0.20, 0.25, 0.10, 0.12))))),
           result("susi_readings", "susi_equatorial", names, trace="equatorial", jitter=dict(zip(names, map(jit, (0.20, 0.25, 0.10, 0.30)))))]
    bw = np.array([[4.5, 230.0, 120.0], [6.1, 57.0, 40.0]])
    loops = xr.Dataset({v: (("scenario", "tracker"), bw) for v in ("bandwidth_hz", "bandwidth_weighted_hz", "T_median", "p_median", "weight_median",
                                                                   "s_phi", "s_f")},
                       coords={"scenario": ["susi_high_latitude", "susi_equatorial"], "tracker": names[1:],
                               "reading": ("tracker", ["none", "literal_cycles", "eq8_only"])}, attrs={"product": "susi_readings_loops"})
    out = susi_table_readings(*res, loops)
    verdicts = out["table_readings_verdict"][0].set_index("reading")["verdict"]
    assert verdicts.to_dict() == {"U1 as declared (literal, eq. 8 / (2 pi)^2)": "explains", "U2 (eq. 8 alone)": "explains part"}
    long = out["table_readings_long"][0].set_index(["scenario", "tracker"])
    assert long.loc[("susi_equatorial", "susi_sakf_u1"), "bandwidth_hz"] == 57.0
    assert long.loc[("susi_high_latitude", "susi_sakf_u2"), "discriminator_below_pll_and_akf"] == "holds"
    assert long.loc[("susi_equatorial", "susi_sakf_u2"), "discriminator_below_pll_and_akf"] == "does not hold"
    grid, title, note = out["table_readings"]
    assert "SURROGATE" in title and len(grid) == 8 and "explains part" in set(grid["verdict (both scenarios)"])
