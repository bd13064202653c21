"""Carrier-aided noncoherent E-L DLL (scintrack.navigation.dll) in closed loop on the correlator model.

Independent references written here:

* the discriminator's noise-free shape from the C/A triangle;
* the loop's noise bandwidth from the impulse response of its transfer
  function (scipy), and its noise-free integration-level recursion derived
  from the code-NCO physics;
* for Delta = 1 (E and L noises independent), the exact mean slope and
  variance of the normalised envelope discriminator by numerical integration
  over the two Rician envelopes, hence the exact linear-loop jitter, against
  which the Monte Carlo is tested; the Kaplan & Hegarty closed form is then
  tested with the model tolerance those integrals quantify.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal, stats

from scintrack.navigation import dll
from scintrack.signals.gps import correlator
from scintrack.signals.gps.correlator import NoiseStream

T1 = 1e-3


def stream(seed=11, spacing=1.0):
    return NoiseStream(seed, "test_dll", spacing)


# --- discriminator and loop design --------------------------------------------------


@pytest.mark.parametrize("spacing", [0.2, 0.5, 1.0, 1.5])
def test_discriminator_unit_slope_and_shape(spacing):
    """Noise-free: D = dtau for |dtau| <= min(Delta/2, 1 - Delta/2); beyond, the triangle's ratio."""
    gain = dll.discriminator_gain(spacing)
    assert gain == pytest.approx(1.0 - spacing / 2.0)
    lin = min(spacing / 2.0, 1.0 - spacing / 2.0)
    for dtau in np.linspace(-lin, lin, 41):
        y = correlator.correlate(3.0, 1.0, dtau, 0.7, 0.0, T1, spacing)  # any phase: envelopes
        assert dll.discriminator(y[0], y[3], y[2], y[5], gain) == pytest.approx(dtau, abs=1e-12)
    if spacing < 1.0:  # E and L on the same side of the peak: (|L|-|E|)/(|L|+|E|) = Delta / (2 (1 - dtau))
        for dtau in np.linspace(spacing / 2.0 + 0.01, 1.0 - spacing / 2.0 - 0.01, 7):
            y = correlator.correlate(3.0, -1.0, dtau, 0.0, 0.0, T1, spacing)
            want = gain * spacing / (2.0 * (1.0 - dtau))
            assert dll.discriminator(y[0], y[3], y[2], y[5], gain) == pytest.approx(want, rel=1e-12)
    assert dll.discriminator(0.0, 0.0, 0.0, 0.0, gain) == 0.0


@pytest.mark.parametrize("bl, n_int", [(0.5, 1), (2.0, 1), (2.0, 20), (10.0, 20)])
def test_loop_gain_gives_noise_bandwidth(bl, n_int):
    """B_L = sum h^2 / (2T) of H(z) = (g/2)(z+1)/(z^2 - (1-g/2) z + g/2), h from scipy; DC gain 1."""
    t = n_int * T1
    g = dll.loop_gain(bl, t)
    _, (h,) = signal.dimpulse(([g / 2.0, g / 2.0], [1.0, -(1.0 - g / 2.0), g / 2.0], 1.0), n=int(40 / g))
    assert np.sum(h) == pytest.approx(1.0, abs=1e-9)
    assert np.sum(h**2) / (2.0 * t) == pytest.approx(bl, rel=1e-9)
    assert dll.noise_bandwidth(g, t) == pytest.approx(bl, rel=1e-12)
    assert g / t == pytest.approx(4.0 * bl, rel=2.5 * bl * t)  # the analog K = 4 B_L for B_L T << 1


def test_code_carrier_ratio():
    assert dll.CARRIER_PER_CHIP == pytest.approx(1540.0, abs=1e-9)


# --- noise-free dynamics --------------------------------------------------------------


def noise_free(n_ep, f_err, dtau0, n_int, bl, spacing=1.0, trials=1):
    t = np.arange(n_ep) * T1
    phase = 2.0 * np.pi * f_err * t  # carrier phase error at epoch starts, consistent with f_err
    return dll.run(
        np.zeros((trials, n_ep, 6)), 45.0, np.ones(n_ep), phase, f_err,
        spacing_chips=spacing, bandwidth_hz=bl, integration_ms=n_int, dtau0_chips=dtau0,
    )


def test_aiding_drift_before_first_update():
    """Until the first update the code NCO runs at 1.023e6 (1 + (f_D + f_err)/f_L1) against the true
    1.023e6 (1 + f_D/f_L1): dtau = dtau0 + integral of 1.023e6 f_err / f_L1 = f_err t / 1540."""
    f_err = np.linspace(-40.0, 25.0, 20)  # a carrier tracker frequency error changing each epoch
    out = dll.run(np.zeros((1, 20, 6)), 45.0, np.ones(20), 0.0, f_err, spacing_chips=1.0, bandwidth_hz=1.0,
                  integration_ms=20, dtau0_chips=0.1)[0]
    start = 0.1 + np.concatenate(([0.0], np.cumsum(f_err * T1 * dll.F_CA / dll.F_L1)))
    np.testing.assert_allclose(out, start[:-1] + 0.5 * f_err * T1 / 1540.0, atol=1e-15)


@pytest.mark.parametrize("n_int", [1, 20])
def test_pull_in_follows_loop_recursion(n_int):
    """Integration means obey x_{j+1} = x_j + r T - g (x_j + x_{j-1})/2 (x_{-1} = 0, x_0 = dtau0 + r T/2).

    Derivation: the rate during integration j is r - K D_{j-1}, the mean error
    of an integration sits half a rate-step after its start, and D_j = x_j
    exactly in the linear region (noise-free, constant carrier phase).
    """
    bl, dtau0 = 2.0, 0.3
    t = n_int * T1
    g = dll.loop_gain(bl, t)
    n_j = int(3.0 / t)
    out = noise_free(n_j * n_int, 0.0, dtau0, n_int, bl)[0]
    got = out.reshape(n_j, n_int).mean(axis=1)
    want = np.empty(n_j)
    prev, want[0] = 0.0, dtau0
    for j in range(n_j - 1):
        want[j + 1] = want[j] - g * (want[j] + prev) / 2.0
        prev = want[j]
    np.testing.assert_allclose(got, want, atol=1e-13)
    # first order: decays like exp(-K t) with K = 4 B_L (to O(g))
    tj = (np.arange(n_j) + 0.5) * t
    assert np.max(np.abs(got - dtau0 * np.exp(-4.0 * bl * tj))) < 1.5 * g * dtau0


@pytest.mark.parametrize("n_int", [1, 20])
def test_constant_frequency_error_gives_ramp_lag(n_int):
    """A constant aiding error f_err is a code ramp r = f_err/1540; the first-order loop settles at r/K.

    Analog: e(t) = (r / K)(1 - exp(-K t)), K = 4 B_L; the discrete loop's
    lag is r T / g exactly and its transient matches the analog one to
    O(g) (the correction acts one integration late).
    """
    bl, f_err = 2.0, -30.0
    t = n_int * T1
    g = dll.loop_gain(bl, t)
    out = noise_free(4000, f_err, 0.0, n_int, bl)[0]
    r = f_err / 1540.0
    lag = dll.steady_state_lag_chips(f_err, bl, t)
    assert lag == pytest.approx(r * t / g, rel=1e-12)
    assert lag == pytest.approx(r / (4.0 * bl), rel=2.5 * bl * t)
    np.testing.assert_allclose(out[-3 * n_int :], lag, rtol=1e-9)  # steady: the NCO rate matches, dtau is flat
    k = 4.0 * bl
    tm = (np.arange(4000) + 0.5) * T1
    assert np.max(np.abs(out - lag * (1.0 - np.exp(-k * tm)))) < 1.5 * g * abs(lag)


def test_integrations_aligned_with_bit_edges():
    """first_in_bit = 7: the first 13 epochs are a partial integration (no update: the loop coasts on the
    aiding), after which the loop is the bit-aligned loop started at epoch 13 with that code error."""
    st = stream()
    n_ep, lead = 2013, 13
    bits = np.where(((np.arange(n_ep) + 7) // 20) % 2 == 0, 1.0, -1.0)  # edges at epochs 13, 33, ...
    noise = st.epochs([0, 1], 0, 0, n_ep)
    kw = dict(spacing_chips=1.0, bandwidth_hz=2.0, integration_ms=20)
    out = dll.run(noise, 35.0, bits, 0.2, 3.0, first_in_bit=7, dtau0_chips=0.1, **kw)
    coast = 0.1 + (np.arange(lead) + 0.5) * T1 * 3.0 / 1540.0
    np.testing.assert_allclose(out[:, :lead], np.broadcast_to(coast, (2, lead)), atol=1e-14)
    start = 0.1 + lead * T1 * 3.0 / 1540.0
    rest = dll.run(noise[:, lead:], 35.0, bits[lead:], 0.2, 3.0, first_in_bit=0, dtau0_chips=start, **kw)
    np.testing.assert_allclose(out[:, lead:], rest, atol=1e-12)
    with pytest.raises(ValueError, match="bit edges"):
        dll.run(noise, 35.0, bits, 0.2, 3.0, first_in_bit=0, **kw)


# --- thermal noise jitter ----------------------------------------------------------------


def rice_ratio_moments(nu_e, nu_l, step=0.01):
    """E[R] and E[R^2] of R = (|L|-|E|)/(|L|+|E|) with independent Rician |E|, |L| (unit noise per component)."""
    lo, hi = max(0.0, min(nu_e, nu_l) - 10.0), max(nu_e, nu_l) + 10.0
    x = np.arange(lo, hi + step, step)
    w = np.full(x.size, step)
    w[0] = w[-1] = step / 2.0
    pe, pl = stats.rice.pdf(x, nu_e) * w, stats.rice.pdf(x, nu_l) * w
    num, den = x[None, :] - x[:, None], x[None, :] + x[:, None]
    ratio = np.divide(num, den, out=np.zeros_like(num), where=den > 0)
    joint = pe[:, None] * pl[None, :]
    assert abs(joint.sum() - 1.0) < 1e-5
    return float(np.sum(joint * ratio)), float(np.sum(joint * ratio**2))


def exact_linear_jitter(cn0_dbhz, n_int, bl):
    """(std of dtau per epoch, slope s, input-referred var(D)/s^2) for Delta = 1 from the Rician integrals.

    With n_int summed 1-ms outputs the E/L envelopes are Rician with
    nu = sqrt(2 C/N0 T) R(dtau -+ 1/2), sigma = 1.  The loop with D = s x + n
    is the design loop with gain g s and input noise n / s, so
    var(x) = var(n)/s^2 * gs / (2 - gs); within an integration the error
    ramps at the rate -K D_{j-1}, adding g^2 var(D_{j-1}) (n^2 - 1)/(12 n^2).
    """
    t = n_int * T1
    amp = np.sqrt(2.0 * 10.0 ** (cn0_dbhz / 10.0) * t)
    h = 1e-3
    m_plus, _ = rice_ratio_moments(amp * (0.5 - h), amp * (0.5 + h))
    _, q0 = rice_ratio_moments(amp / 2.0, amp / 2.0)
    slope = 0.5 * m_plus / h  # symmetric: E[R](-h) = -E[R](h); gain 1/2
    var_d = 0.25 * q0
    g = dll.loop_gain(bl, t)
    gs = g * slope
    var_x = var_d / slope**2 * gs / (2.0 - gs)
    var_e = var_x + g**2 * (slope**2 * var_x + var_d) * (n_int**2 - 1) / (12.0 * n_int**2)
    return np.sqrt(var_e), slope, var_d / slope**2


@pytest.mark.parametrize("cn0, n_int, bl", [(45.0, 1, 5.0), (45.0, 20, 2.0), (25.0, 20, 2.0)])
def test_thermal_jitter(cn0, n_int, bl):
    """Closed-loop jitter over 100 independent trials against the exact linear loop and Kaplan & Hegarty.

    Tolerance: the standard error of the mean square is taken from the spread
    of the 100 per-trial mean squares (independent trials; the first 10/g
    integrations of each are dropped as transient), and must itself be below
    1.5 %; the simulation must match the exact linear-loop variance within
    4 standard errors.  Against the closed form: at 45 dB-Hz the Rician
    integrals put the exact linear-loop sigma 1.6 % below K&H at C/N0 T = 31.6
    (slope 0.963) and 0.1 % at 632 (slope 0.998), so sigma_sim / sigma_KH - 1
    must be within 2 % + 2 standard errors (in sigma, half those of the variance).
    At 25 dB-Hz, 20 ms the K&H noise term still holds for the noise referred
    to the input (var(D)/s^2 within 5 %), but the Rician slope (0.70) narrows
    the closed loop, so the simulated sigma is about sqrt(0.70) of K&H's and
    below it.
    """
    t = n_int * T1
    g = dll.loop_gain(bl, t)
    n_ep = 12000 if n_int == 1 else 24000
    skip = int(10.0 / g) * n_int
    out = dll.track(stream(), range(100), 3, 0, cn0, np.ones(n_ep), 0.0, 0.0, bandwidth_hz=bl, integration_ms=n_int)
    ms = np.mean(out[:, skip:] ** 2, axis=1)
    var_sim, se = ms.mean(), ms.std(ddof=1) / np.sqrt(ms.size)
    assert se / var_sim < 0.015
    sigma_lin, slope, var_in = exact_linear_jitter(cn0, n_int, bl)
    assert abs(var_sim / sigma_lin**2 - 1.0) < 4.0 * se / var_sim
    assert abs(out[:, skip:].mean()) < 4.0 * np.sqrt(se)  # no bias
    kh = dll.thermal_jitter_chips(cn0, bl, 1.0, t)
    kh_disc_var = 1.0 / (4.0 * t * 10.0 ** (cn0 / 10.0)) * (1.0 + 2.0 / (t * 10.0 ** (cn0 / 10.0)))
    if cn0 >= 45.0:
        assert abs(sigma_lin / kh - 1.0) < 0.02
        assert abs(np.sqrt(var_sim) / kh - 1.0) < 0.02 + 2.0 * se / var_sim
    else:
        assert slope == pytest.approx(0.70, abs=0.01)
        assert abs(var_in / kh_disc_var - 1.0) < 0.05
        assert np.sqrt(var_sim) < kh
        assert np.sqrt(var_sim) / kh == pytest.approx(np.sqrt(slope), rel=0.05)


def test_closed_form_matches_notes_example():
    """Notes Sec. 2.3: 15 dB-Hz, T = 20 ms, Delta = 1, B_L = 0.05 Hz -> 0.057 chip."""
    assert dll.thermal_jitter_chips(15.0, 0.05, 1.0, 0.02) == pytest.approx(0.057, abs=0.001)


# --- noise conventions, determinism, input checks --------------------------------------


def test_deterministic_and_independent_of_batching():
    st = stream()
    args = (45.0, np.ones(3000), 0.1, -2.0)
    a = dll.track(st, [0, 1, 2], 0, 500, *args, bandwidth_hz=2.0)
    b = dll.track(stream(), [0, 1, 2], 0, 500, *args, bandwidth_hz=2.0)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(dll.track(st, [1], 0, 500, *args, bandwidth_hz=2.0)[0], a[1])
    assert not np.array_equal(a[0], a[1])
    assert not np.array_equal(dll.track(stream(seed=12), [0], 0, 500, *args, bandwidth_hz=2.0)[0], a[0])
    assert not np.array_equal(dll.track(st, [0], 1, 500, *args, bandwidth_hz=2.0)[0], a[0])


def test_uses_the_streams_early_late_columns_only():
    """Same draws as NoiseStream.epochs; the prompt columns (the carrier tracker's) do not enter the DLL."""
    st = stream(spacing=0.5)
    bits = np.repeat(np.where(np.arange(10) % 3 == 0, 1.0, -1.0), 20)
    cn0 = np.linspace(45.0, 30.0, 200)
    got = dll.track(st, [4, 5], 2, 1000, cn0, bits, 0.3, 1.5, bandwidth_hz=1.0, integration_ms=20, dtau0_chips=[0.05, -0.05])
    noise = st.epochs([4, 5], 2, 1000, 1200)
    kw = dict(spacing_chips=0.5, bandwidth_hz=1.0, integration_ms=20, dtau0_chips=np.array([0.05, -0.05]))
    np.testing.assert_array_equal(dll.run(noise, cn0, bits, 0.3, 1.5, **kw), got)
    noise[..., [1, 4]] = 123.0
    np.testing.assert_array_equal(dll.run(noise, cn0, bits, 0.3, 1.5, **kw), got)


def test_fixed_gain_equals_agc():
    """'fixed' scales every output by sigma = sqrt(N0_eff/N0_ref): the normalised discriminator is unchanged."""
    st = stream()
    cn0 = np.linspace(46.0, 20.0, 2000)
    agc = dll.track(st, [0], 0, 0, cn0, np.ones(2000), 0.0, 0.0, bandwidth_hz=2.0)
    fixed = dll.track(st, [0], 0, 0, cn0, np.ones(2000), 0.0, 0.0, bandwidth_hz=2.0, gain="fixed", cn0_ref_dbhz=46.0)
    np.testing.assert_allclose(fixed, agc, atol=1e-12)


def test_bad_input():
    st = stream()
    with pytest.raises(ValueError, match="bit edge"):
        dll.track(st, [0], 0, 0, 45.0, np.r_[np.ones(10), -np.ones(30)], 0.0, 0.0, bandwidth_hz=1.0, integration_ms=20)
    with pytest.raises(ValueError, match="B_L"):
        dll.track(st, [0], 0, 0, 45.0, np.ones(40), 0.0, 0.0, bandwidth_hz=20.0, integration_ms=20)
    with pytest.raises(ValueError, match="bandwidth_hz"):
        dll.track(st, [0], 0, 0, 45.0, np.ones(40), 0.0, 0.0, bandwidth_hz=0.0)
    for bad in (0, 3):
        with pytest.raises(ValueError, match="integration_ms"):
            dll.track(st, [0], 0, 0, 45.0, np.ones(40), 0.0, 0.0, bandwidth_hz=1.0, integration_ms=bad)
    with pytest.raises(ValueError, match="first_in_bit"):
        dll.track(st, [0], 0, 0, 45.0, np.ones(40), 0.0, 0.0, bandwidth_hz=1.0, first_in_bit=20)
    with pytest.raises(ValueError, match="spacing_chips"):
        dll.run(np.zeros((1, 4, 6)), 45.0, np.ones(4), 0.0, 0.0, spacing_chips=2.0, bandwidth_hz=1.0)
    with pytest.raises(ValueError, match=r"\(trials, epochs, 6\)"):
        dll.run(np.zeros((1, 4, 3)), 45.0, np.ones(4), 0.0, 0.0, spacing_chips=1.0, bandwidth_hz=1.0)
    with pytest.raises(ValueError, match="freq_error_hz"):
        dll.run(np.zeros((2, 4, 6)), 45.0, np.ones(4), 0.0, np.zeros((3, 4)), spacing_chips=1.0, bandwidth_hz=1.0)
    with pytest.raises(ValueError, match=r"\+-1"):
        dll.run(np.zeros((1, 4, 6)), 45.0, np.zeros(4), 0.0, 0.0, spacing_chips=1.0, bandwidth_hz=1.0)
    with pytest.raises(ValueError, match="dtau0_chips"):
        dll.run(np.zeros((2, 4, 6)), 45.0, np.ones(4), 0.0, 0.0, spacing_chips=1.0, bandwidth_hz=1.0, dtau0_chips=[0.0] * 3)
