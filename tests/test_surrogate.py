"""The phase-screen surrogate: calibrated S4 and sigma_phi, frequency ordering, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from scintrack.data.surrogate import surrogate_event, surrogate_params, surrogate_version
from scintrack.io import content_hash
from scintrack.signals import phase_screen as ps


def _config(seed=7, s4=0.8, sigma=1.0):
    return {
        "seed": seed,
        "sampling": {"ts": 0.01},
        "real_traces": {
            "bands": ["L1", "L2", "L5"], "fit_s": 120.0, "eval_s": 120.0,
            "surrogate": {
                "height_m": 350e3, "drift_m_s": 150.0, "outer_scale_m": 1e4, "window_s": 30.0, "detrend_hz": 0.1,
                "events": {"ev": {"s4_l1": s4, "sigma_phi_l1": sigma, "profile": [[0, 0.8], [240, 1.2]]}},
            },
        },
    }


@pytest.fixture(scope="module")
def event():
    return surrogate_event(surrogate_params(_config(), "ev"))


def test_configured_s4_and_sigma_phi_at_l1_are_achieved(event):
    per = int(30.0 / 0.01)
    s4 = ps.window_s4(event["amplitude"].sel(band="L1").values.astype(float) ** 2, per).mean()
    sig = ps.window_sigma_phi(event["phase"].sel(band="L1").values.astype(float), 0.01, per).mean()
    assert abs(s4 - 0.8) < 0.01
    assert abs(sig - 1.0) < 0.1  # calibration tolerance on a 0.1 spectral-index grid


def test_lower_frequencies_scintillate_more(event):
    s4 = dict(zip(event["band"].values, event["mean_s4"].values))
    sig = dict(zip(event["band"].values, event["mean_sigma_phi"].values))
    # L1 1575.42 MHz > L2 1227.60 MHz > L5 1176.45 MHz
    assert s4["L2"] > s4["L1"] and s4["L5"] > s4["L1"]
    assert sig["L5"] > sig["L2"] > sig["L1"]
    # weak-scatter phase scales as 1/f: the L2/L1 sigma_phi ratio is near f_L1/f_L2 = 1.28
    assert 1.1 < sig["L2"] / sig["L1"] < 1.6


def test_amplitude_has_unit_mean_power_and_deep_fades(event):
    rho = event["amplitude"].values.astype(float)
    assert np.allclose((rho**2).mean(axis=1), 1.0, atol=0.1)
    assert 20 * np.log10(rho[0].min()) < -15  # severe event: fades deeper than -15 dB


def test_phase_is_detrended_and_bounded(event):
    th = event["phase"].sel(band="L1").values.astype(float)
    assert abs(th.mean()) < 0.2 and np.abs(th).max() < 10 * th.std()


def test_labelled_surrogate(event):
    assert event.attrs["source"] == "surrogate"
    assert "SURROGATE" in event.attrs["title"] and "not JRC" in event.attrs["title"]


def test_same_seed_same_content_hash_and_version_tracks_parameters(event):
    again = surrogate_event(surrogate_params(_config(), "ev"))
    assert content_hash(again) == content_hash(event)
    assert surrogate_version(surrogate_params(_config(seed=8), "ev")) != surrogate_version(surrogate_params(_config(), "ev"))


def test_fresnel_propagation_conserves_power_and_is_identity_at_zero_distance():
    rng = np.random.default_rng(0)
    phi = ps.shaped_screen(ps.white_spectrum(rng, 4096), 4096, 1.5, 3.0, 1e4)
    u = ps.fresnel_propagate(phi, 1.5, ps.GPS_CARRIERS_HZ["L1"], 350e3)
    assert np.isclose(np.mean(np.abs(u) ** 2), 1.0, atol=1e-12)
    u0 = ps.fresnel_propagate(phi, 1.5, ps.GPS_CARRIERS_HZ["L1"], 0.0)
    assert np.allclose(u0, np.exp(1j * phi), atol=1e-12)


@pytest.mark.parametrize("scale", [1e-3, 3.0, 1e4])
def test_fresnel_propagation_is_numpys_expression_bit_for_bit(scale):
    """The compiled unit phasor gives numpy's ``exp(1j * phase)`` (libm's cos and sin), so the field is the same bits."""
    rng = np.random.default_rng(7)
    phase = np.concatenate([[0.0, -0.0, np.pi, -np.pi], np.cumsum(rng.normal(size=4092)) * scale])
    field = np.fft.ifft(np.fft.fft(np.exp(1j * phase)) * ps._fresnel_transfer(phase.size, 0.1, ps.GPS_CARRIERS_HZ["L2"], 350e3))
    got = ps.fresnel_propagate(phase, 0.1, ps.GPS_CARRIERS_HZ["L2"], 350e3)
    assert got.dtype == complex and np.array_equal(got.view(np.uint64), field.view(np.uint64))
    out = np.empty(phase.size, dtype=complex)
    ps._unit_phasor(phase, out)
    assert np.array_equal(out.view(np.uint64), np.exp(1j * phase).view(np.uint64))


def test_unreachable_target_is_a_clear_error():
    with pytest.raises(ValueError, match="sigma_phi at L1"):
        surrogate_event(surrogate_params(_config(sigma=9.0), "ev"))
