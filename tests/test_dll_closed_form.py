"""The jammed DLL's code noise against the Betz & Kolodziejski closed form (scintrack.navigation.dll).

The Zhao receiver's DLL (``zhao_receiver.dll``: Delta = 1 chip, T = 20 ms,
B_L = 0.05 Hz, ``gain="fixed"`` referred to the clean 46 dB-Hz) runs the
normalised envelope discriminator ``(1 - Delta/2)(|L| - |E|)/(|L| + |E|)``.
Open loop, on the correlator model's noisy E/L summed over 20 ms exactly as
``dll_kernel`` sums them, the test measures that discriminator's mean slope
``s`` (code errors +-h on the same noise) and its variance at 0.  With
``D = s x + n`` the loop of gain ``g`` is the design loop with gain ``g s``,
so (module docstring of :mod:`scintrack.navigation.dll`)

    var(x) = 2 B_eff T var(D) / s^2,  B_eff = noise_bandwidth(g s, T) ~ s B_L.

The closed form ``B_L Delta/(2 C/N0) (1 + 2/((2 - Delta) T C/N0))`` is
``2 B_L T var_BK`` with ``var_BK`` the variance of the early-minus-late
*power* discriminator normalised by the *expected* signal power,
``(|L|^2 - |E|^2) / (2 a^2)`` (unit slope at every C/N0; ``a`` the summed
signal amplitude): the test computes that discriminator on the same samples
and finds both its unit slope and ``var_BK``.

Results: at 46 dB-Hz ``s = 1`` and the receiver's loop meets the closed form
(the pre-declared 15 % criterion).  At 15 dB-Hz (``C/N0 T = 0.63``) the
noisy envelope sum in the denominator cuts the slope to ``s = 0.125``; the
loop then has ``B_eff = 0.125 B_L`` and its noise, referred to the input, is
1.34 ``var_BK``: sigma is 2.4 times below the closed form.  A closed-loop run
of the receiver's DLL matches the effective-bandwidth prediction within 15 %.

The position spread (``table_enu_vs_paper``) is each trial's std of its 1-Hz
fixes over the 120-s jammed segment.  The narrowed loop's code error has a
correlation time ``T / (g s)`` of 40 s, so a 120-s segment that starts from
the clean (almost zero) error holds two thirds of the stationary sigma: the
receiver's DLL, run closed loop over that segment, has a per-trial std
3.3-4.1 times below the closed form, as the linear loop with the measured
slope predicts.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from scintrack.navigation import dll
from scintrack.signals.gps import correlator
from scintrack.signals.gps.correlator import NoiseStream

DELTA, N_INT, B_L = 1.0, 20, 0.05  # the receiver's DLL (config zhao_receiver.dll)
T = N_INT * dll.CODE_PERIOD_S
CN0_CLEAN, CN0_JAMMED = 46.0, 15.0
H = 0.1  # code error of the slope measurement (chips), inside the linear range |dtau| < Delta/2
GAIN = {"gain": "fixed", "cn0_ref_dbhz": CN0_CLEAN}  # the receiver's normalisation


def stream() -> NoiseStream:
    return NoiseStream(23, "test_dll_closed_form", DELTA)


def summed_epl(cn0: float, dtau: float, trials: int = 40, integrations: int = 1000) -> np.ndarray:
    """E/P/L summed over each 20-ms integration, (trials * integrations, 6), at a fixed code error ``dtau``."""
    n = N_INT * integrations
    x = correlator.open_loop(stream(), range(trials), 1, 0, cn0, np.ones(n), dll.CODE_PERIOD_S, code_offset_chips=-dtau, **GAIN)
    return x.reshape(trials, integrations, N_INT, 6).sum(axis=2).reshape(-1, 6)


def envelope_discriminator(s: np.ndarray) -> np.ndarray:
    """The receiver's discriminator (dll.discriminator, its gain 1 - Delta/2) on every summed epoch."""
    gain = dll.discriminator_gain(DELTA)
    return np.array([dll.discriminator(ie, qe, il, ql, gain) for ie, qe, il, ql in s[:, [0, 3, 2, 5]]])


def power_discriminator(s: np.ndarray, cn0: float) -> np.ndarray:
    """``(|L|^2 - |E|^2) / (2 a^2)``, ``a`` the expected summed signal amplitude: unit slope for Delta = 1."""
    a, _ = correlator.gains(cn0, dll.CODE_PERIOD_S, GAIN["gain"], GAIN["cn0_ref_dbhz"])
    amp = N_INT * float(a)
    return ((s[:, 2] ** 2 + s[:, 5] ** 2) - (s[:, 0] ** 2 + s[:, 3] ** 2)) / (2.0 * amp**2)


def measured(cn0: float, discriminator) -> tuple[float, float]:
    """(mean slope, variance at dtau = 0) of a discriminator, from the same noise at -H, 0, +H."""
    d = {h: discriminator(summed_epl(cn0, h)) for h in (-H, 0.0, H)}
    return float(np.mean(d[H] - d[-H]) / (2 * H)), float(np.var(d[0.0]))


def closed_form_var(cn0: float, bandwidth: float = B_L) -> float:
    return float(dll.thermal_jitter_chips(cn0, bandwidth, DELTA, T)) ** 2


def input_var_bk(cn0: float) -> float:
    """``var_BK``: the closed form's discriminator variance, ``closed form / (2 B_L T)``."""
    c = 10.0 ** (cn0 / 10.0) * T
    return DELTA / (4.0 * c) * (1.0 + 2.0 / ((2.0 - DELTA) * c))


def loop_var(slope: float, var_d: float, bandwidth: float = B_L) -> tuple[float, float]:
    """(tracking variance, effective B_L) of the loop whose discriminator has ``slope`` and ``var_d``."""
    b_eff = dll.noise_bandwidth(dll.loop_gain(bandwidth, T) * slope, T)
    return 2.0 * b_eff * T * var_d / slope**2, b_eff


@pytest.fixture(scope="module")
def envelope():
    return {cn0: measured(cn0, envelope_discriminator) for cn0 in (CN0_CLEAN, CN0_JAMMED)}


def test_closed_form_is_the_expected_power_discriminator():
    """Betz & Kolodziejski's variance is that of the E-L power discriminator normalised by the expected power, at any C/N0."""
    assert closed_form_var(15.0) == pytest.approx(2 * B_L * T * input_var_bk(15.0), rel=1e-12)
    for cn0 in (CN0_CLEAN, CN0_JAMMED):
        slope, var_d = measured(cn0, lambda s, c=cn0: power_discriminator(s, c))
        assert slope == pytest.approx(1.0, abs=0.02 if cn0 == CN0_CLEAN else 0.05)
        assert var_d == pytest.approx(input_var_bk(cn0), rel=0.05)


def test_clean_dll_meets_the_closed_form(envelope):
    """46 dB-Hz: unit slope, and the receiver's loop is within 15 % of the closed form (within 2 % in fact)."""
    slope, var_d = envelope[CN0_CLEAN]
    assert slope == pytest.approx(1.0, abs=0.01)
    var_x, b_eff = loop_var(slope, var_d)
    assert b_eff == pytest.approx(B_L, rel=0.01)
    assert np.sqrt(var_x / closed_form_var(CN0_CLEAN)) == pytest.approx(1.0, abs=0.02)


def test_jammed_dll_gain_collapse_explains_the_smaller_spread(envelope):
    """15 dB-Hz: slope 0.125, so B_eff = 0.125 B_L; the input-referred noise is 1.34 var_BK; sigma is 2.4x below the closed form."""
    slope, var_d = envelope[CN0_JAMMED]
    assert 0.11 < slope < 0.14
    var_x, b_eff = loop_var(slope, var_d)
    assert b_eff / B_L == pytest.approx(slope, rel=0.01)  # the loop narrows in proportion to the gain (B_L T << 1)
    assert var_d / slope**2 / input_var_bk(CN0_JAMMED) == pytest.approx(1.34, abs=0.1)
    ratio = np.sqrt(closed_form_var(CN0_JAMMED) / var_x)
    assert 2.2 < ratio < 2.7  # outside the pre-declared 15 %: the closed form does not describe this discriminator here
    assert ratio == pytest.approx(np.sqrt(input_var_bk(CN0_JAMMED) * slope**2 / var_d / slope), rel=0.01)


def test_closed_loop_dll_follows_its_effective_bandwidth(envelope):
    """The receiver's DLL closed loop at 15 dB-Hz (B_L = 1 Hz so that the test is short; B_eff scales with s at any
    B_L T << 1): its code-error variance is the effective-bandwidth prediction within 15 %, and far below the
    closed form at the nominal B_L."""
    slope, var_d = envelope[CN0_JAMMED]
    bandwidth = 1.0
    predicted, b_eff = loop_var(slope, var_d, bandwidth)
    settle, keep = 10_000, 40_000  # epochs: 10 s (5 time constants T / (g s) = 2 s), then 40 s
    n = settle + keep
    ms = []
    st = stream()
    for first in range(0, 100, 25):
        trials = list(range(1000 + first, 1025 + first))
        out = dll.track(st, trials, 2, 0, CN0_JAMMED, np.ones(n), 0.0, 0.0, bandwidth_hz=bandwidth, integration_ms=N_INT, **GAIN)
        ms.append(np.mean(out[:, settle:] ** 2, axis=1))
    ms = np.concatenate(ms)
    var_sim, se = ms.mean(), ms.std(ddof=1) / np.sqrt(ms.size)
    assert se / var_sim < 0.06
    assert var_sim == pytest.approx(predicted, rel=0.15)
    assert var_sim < 0.25 * closed_form_var(CN0_JAMMED, bandwidth)


def test_jammed_segment_spread_is_the_narrowed_loop_seen_for_120_s(envelope):
    """The receiver's DLL over the 120-s jammed segment, started from a zero code error as after the clean part: the
    mean over trials of each trial's std of its 1-Hz samples (the ENU std's statistic) against the linear loop with the
    measured slope and noise (the recursion x_{j+1} = x_j - g (D_j + D_{j-1}) / 2 of the DLL's docstring, D = s x + n)."""
    slope, var_d = envelope[CN0_JAMMED]
    g = dll.loop_gain(B_L, T)
    n_int, per_fix = 6000, 50  # 120 s of 20-ms integrations; 1-Hz fixes
    noise = np.random.default_rng(5).normal(0.0, np.sqrt(var_d), (4000, n_int))
    x = signal.lfilter([0.0, -g / 2, -g / 2], [1.0, -(1.0 - g * slope / 2), g * slope / 2], noise, axis=1)
    model = float(x[:, ::per_fix].std(axis=1, ddof=1).mean())
    stationary = np.sqrt(loop_var(slope, var_d)[0])
    assert model / stationary == pytest.approx(0.66, abs=0.03)
    st = stream()
    stds = []
    for first in range(0, 64, 16):
        out = dll.track(st, list(range(2000 + first, 2016 + first)), 3, 0, CN0_JAMMED, np.ones(n_int * N_INT), 0.0, 0.0, bandwidth_hz=B_L,
                        integration_ms=N_INT, **GAIN)
        stds.append(out[:, :: per_fix * N_INT].std(axis=1, ddof=1))
    stds = np.concatenate(stds)
    assert stds.std(ddof=1) / np.sqrt(stds.size) < 0.05 * stds.mean()
    assert stds.mean() == pytest.approx(model, rel=0.15)
    assert 3.3 < np.sqrt(closed_form_var(CN0_JAMMED)) / stds.mean() < 4.1
