"""Cornell Scintillation Model: S4, decorrelation time, normalisation, seeding."""

from __future__ import annotations

import numpy as np
import pytest

from scintrack.signals.csm import (
    BETA0,
    Segment,
    diffuse_field_acf,
    generate_csm,
    generate_csm_profile,
    rice_k_from_s4,
    s4_index,
)

TS = 0.01


@pytest.mark.parametrize("s4", [0.3, 0.5, 0.7, 0.9])
def test_measured_s4_within_3_percent(s4):
    real = generate_csm(seed=11, name=f"s4test-{s4}", trials=range(20), n_epochs=30_000, ts=TS, s4=s4, tau0=0.3, warmup=500)
    pooled = float(s4_index(real.z.ravel()))
    assert abs(pooled - s4) / s4 < 0.03, pooled


@pytest.mark.parametrize("s4", [0.2, 0.5, 0.8, 0.95])
def test_rice_k_matches_s4_closed_form(s4):
    k = float(rice_k_from_s4(s4))
    # Rice intensity: S4^2 = (1 + 2K) / (1 + K)^2
    assert np.isclose((1 + 2 * k) / (1 + k) ** 2, s4**2, rtol=1e-12)


def test_rice_k_rayleigh_beyond_one():
    assert float(rice_k_from_s4(1.0)) == 0.0
    assert float(rice_k_from_s4(1.3)) == 0.0


def test_analogue_acf_is_one_over_e_at_tau0():
    assert np.isclose(diffuse_field_acf(0.7, 0.7), np.exp(-1), rtol=1e-9)
    assert np.isclose(BETA0, 1.23964643681047)


def _first_crossing(acf: np.ndarray, level: float, dt: float) -> float:
    k = int(np.argmax(acf < level))
    # linear interpolation between lags k-1 and k
    return dt * (k - 1 + (acf[k - 1] - level) / (acf[k - 1] - acf[k]))


@pytest.mark.parametrize("tau0", [0.2, 0.5, 1.0])
def test_diffuse_field_decorrelates_to_1_over_e_at_tau0(tau0):
    real = generate_csm(seed=5, name=f"tau-{tau0}", trials=range(8), n_epochs=60_000, ts=TS, s4=0.9, tau0=tau0, warmup=1000, output="point")
    xi = real.z - real.z.mean(axis=1, keepdims=True)  # remove the line-of-sight term
    nlag = int(3 * tau0 / TS)
    acf = np.array([np.mean(np.real(xi[:, lag:] * np.conj(xi[:, : xi.shape[1] - lag]))) for lag in range(nlag)])
    acf /= acf[0]
    measured = _first_crossing(acf, np.exp(-1), TS)
    assert abs(measured - tau0) / tau0 < 0.10, measured


@pytest.mark.parametrize("output", ["average", "point"])
def test_unit_mean_power(output):
    real = generate_csm(seed=3, name="power", trials=range(4), n_epochs=20_000, ts=TS, s4=0.8, tau0=0.2, warmup=200, output=output)
    power = np.mean(np.abs(real.z) ** 2, axis=1)
    assert np.allclose(power, 1.0, atol=0.01), power


def test_trial_is_independent_of_batch():
    kwargs = dict(seed=42, name="batch", n_epochs=2_000, ts=TS, s4=0.7, tau0=0.3, warmup=100)
    batch = generate_csm(trials=range(10), **kwargs).z
    alone = generate_csm(trials=[7], **kwargs).z
    np.testing.assert_array_equal(batch[7], alone[0])
    assert not np.allclose(batch[6], batch[7])


def test_amplitude_and_phase_views():
    real = generate_csm(seed=1, name="views", trials=[0], n_epochs=3_000, ts=TS, s4=0.9, tau0=0.1)
    np.testing.assert_allclose(real.rho * np.exp(1j * real.theta), real.z, atol=1e-12)
    assert np.all(np.abs(np.diff(real.theta, axis=-1)) < np.pi)


def test_profile_segments_reach_their_s4():
    segments = [Segment(0.0, 0.8, 0.2), Segment(150.0, 0.5, 0.4)]
    real, s4_t, tau0_t = generate_csm_profile(seed=9, name="profile", trials=range(12), n_epochs=30_000, ts=TS, segments=segments, warmup=500)
    first = real.z[:, 1000:14_000]
    second = real.z[:, 17_000:]
    assert abs(float(s4_index(first.ravel())) - 0.8) < 0.05
    assert abs(float(s4_index(second.ravel())) - 0.5) < 0.03
    assert np.all(s4_t[:15_000] == 0.8) and np.all(s4_t[15_000:] == 0.5)
    assert np.all(tau0_t[15_000:] == 0.4)
    for part in (first, second):
        assert abs(np.mean(np.abs(part) ** 2) - 1.0) < 0.05


def test_profile_rejects_bad_segments():
    with pytest.raises(ValueError, match="start_s = 0"):
        generate_csm_profile(seed=1, name="x", trials=[0], n_epochs=100, ts=TS, segments=[Segment(1.0, 0.5, 0.4)])


def test_tau0_too_short_is_a_clear_error():
    with pytest.raises(ValueError, match="too short"):
        generate_csm(seed=1, name="x", trials=[0], n_epochs=100, ts=TS, s4=0.5, tau0=1e-4)
