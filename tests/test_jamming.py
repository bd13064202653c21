"""Spectral separation coefficient and effective C/N0 of a band-limited noise jammer."""

import numpy as np
import pytest

from scintrack.signals.gps import jamming


def test_narrow_jammer_at_centre_sees_the_peak_of_the_ca_spectrum():
    # a very narrow jammer on L1: kappa -> G_s(0) = T_c = 1/1.023 MHz
    assert jamming.spectral_separation(1.0) == pytest.approx(1 / 1.023e6, rel=1e-6)


def test_very_wide_jammer_tends_to_one_over_bandwidth():
    b = 1e9
    assert jamming.spectral_separation(b) * b == pytest.approx(1.0, abs=1e-3)


def test_8mhz_jammer_kappa_from_the_fraction_of_ca_power_in_band():
    # 97.47 % of C/A power lies within +-4 MHz (reference notes, computed independently by Simpson here)
    f = np.linspace(-4e6, 4e6, 2_000_001)
    tc = 1 / 1.023e6
    frac = np.trapezoid(tc * np.sinc(f * tc) ** 2, f)
    assert jamming.spectral_separation(8e6) == pytest.approx(frac / 8e6, rel=1e-5)
    assert frac == pytest.approx(0.9747, abs=2e-4)


def test_js_that_gives_15_dbhz_and_its_round_trip():
    kappa = jamming.spectral_separation(8e6)
    js = jamming.js_for_cn0_db(46.0, 15.0, kappa)
    assert js == pytest.approx(54.14, abs=0.01)
    assert float(jamming.effective_cn0_dbhz(46.0, js, kappa)) == pytest.approx(15.0, abs=1e-9)
    # the config's J/S (54.14 dB) gives 15 dB-Hz within 0.5 dB
    assert abs(float(jamming.effective_cn0_dbhz(46.0, 54.14, kappa)) - 15.0) < 0.5


def test_no_jammer_leaves_cn0_unchanged_and_offset_jammer_hurts_less():
    kappa = jamming.spectral_separation(8e6)
    assert float(jamming.effective_cn0_dbhz(46.0, -np.inf, kappa)) == pytest.approx(46.0)
    assert jamming.spectral_separation(2e6, offset_hz=3e6) < jamming.spectral_separation(2e6)


def test_front_end_renormalises_both_spectra():
    inside = jamming.spectral_separation(8e6, front_end_hz=12.5e6) * 8e6
    # kappa*B = (C/A power in +-4 MHz) / (C/A power in +-6.25 MHz)
    assert inside == pytest.approx(0.97472 / 0.98316, rel=2e-4)


def test_bad_arguments():
    with pytest.raises(ValueError, match="bandwidth"):
        jamming.spectral_separation(0.0)
    with pytest.raises(ValueError, match="below"):
        jamming.js_for_cn0_db(30.0, 35.0, 1e-7)
