"""Closed-loop tracking of raw samples with the project's loops (scintrack.experiments.real_tracking).

A synthetic 4-MS/s recording with known Doppler, code phase, carrier phase and
bit edges (scintrack.signals.gps.iq.synthesise) checks the loops against the
truth and the closed forms; the Pocket SDR capture (0.5 s of GPS L1 at 4 MS/s)
checks what a real recording proves: lock, plausible C/N0, and one bit-edge
offset per satellite.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from scintrack.experiments import real_tracking as rt
from scintrack.navigation import dll
from scintrack.signals.gps import iq
from scintrack.signals.gps.acquisition import acquire, correlate
from scintrack.signals.gps.bit_sync import bit_sync
from scintrack.signals.gps.sample_correlator import SampleCorrelator
from scintrack.signals.recording import read_recording
from scintrack.trackers import blocks
from scintrack.trackers.base import TrackInit
from scintrack.trackers.mm_kf import mm_kf_kernel

REPO = Path(__file__).resolve().parents[1]
CAPTURE = "real/pocketsdr/L1_20211202_084700_4MHz_IQ.bin"
FS = 4e6
DURATION_S = 0.3
#: (prn, C/N0 dB-Hz, Doppler Hz, code phase at t = 0 chips, carrier phase rad, whole code periods of the first bit before t = 0)
TRUTH = ((3, 45.0, 1234.5, 345.6, 0.7, 7), (7, 38.0, -2222.2, 812.3, -2.0, 13))
#: the capture's satellites at 38 dB-Hz or more, and one not in view.  PRN 4 (35 dB-Hz) is there too but left out: at
#: 1 ms its prompt changes sign by noise in ~0.6 % of the epochs, so only ~70 % of its sign changes are bit edges
CAPTURE_PRNS = (16, 18, 26, 29, 31, 32)
ABSENT_PRN = 1
#: the 50-bps data bits of each synthetic satellite
NAV = {prn: np.random.default_rng(prn).choice([-1.0, 1.0], 40) for prn, *_ in TRUTH}


def _wrap_half_cycle(x):
    """Costas phase errors are defined modulo pi: wrap to [-pi/2, pi/2)."""
    return np.mod(x + np.pi / 2, np.pi) - np.pi / 2


@pytest.fixture(scope="module")
def synthetic():
    n_ms = int(DURATION_S / iq.MS) + 1
    svs = [iq.SvSignal.constant_doppler(prn, cn0, n_ms, f, code, phase, nav_bits=NAV[prn], code_periods_into_bit=into)
           for prn, cn0, f, code, phase, into in TRUTH]
    z = iq.synthesise(svs, FS, duration_s=DURATION_S, seed=5)
    acqs = {sv.prn: acquire(z, FS, sv.prn, n_noncoherent=10) for sv in svs}
    settings = rt.TrackingSettings()
    return z, svs, acqs, settings, rt.track_recording(z, FS, acqs, settings)


def test_correlator_repeats_the_open_loop_correlator(synthetic):
    """At a fixed code rate and a carrier phase given at t = 0, period after period, the NCO correlator's E/P/L are
    acquisition.correlate's (same replica, same epochs): its carried code state loses nothing across periods."""
    z, svs, acqs, _, _ = synthetic
    sv = svs[0]
    rate = float(iq.code_rate_hz(sv.doppler_hz[0]))
    ref = correlate(z, FS, sv.prn, sv.code_phase_chips[0], sv.doppler_hz[0], -sv.carrier_phase_rad[0], 120, 1.0)
    corr = SampleCorrelator(z, FS, sv.prn, sv.code_phase_chips[0], rate, spacing_chips=1.0)
    got = [corr.correlate(rate, sv.doppler_hz[0], -sv.carrier_phase_rad[0], 0.0) for _ in range(120)]
    np.testing.assert_array_equal([c.start for c in got], ref.start_index)
    np.testing.assert_array_equal([c.n_samples for c in got], ref.n_samples)
    for name in ("early", "prompt", "late"):
        np.testing.assert_allclose([getattr(c, name) for c in got], getattr(ref, name), rtol=0, atol=1e-9)
    # aligned replica: the prompt is the signal amplitude times the bit (plus noise), the early/late half of it
    amplitude = np.sqrt(10 ** (sv.cn0_dbhz / 10) / FS)
    assert np.mean(np.abs(ref.prompt)) == pytest.approx(amplitude, rel=0.05)
    assert np.mean(np.abs(ref.early)) == pytest.approx(amplitude / 2, rel=0.1)


def test_continuous_carrier_nco_keeps_the_phase():
    """With no phase given the carrier NCO continues: the phase at a period's start is the last one's end."""
    z = np.ones(20_000, dtype=np.complex64)
    corr = SampleCorrelator(z, FS, 5, 100.0, 1.023e6)
    first = corr.correlate(1.023e6, 250.0, 0.3, corr.time(corr.start))
    second = corr.correlate(1.023e6, 250.0)
    assert first.carrier_phase_rad == pytest.approx(0.3)
    assert second.carrier_phase_rad == pytest.approx(0.3 + 2 * np.pi * 250.0 * first.n_samples / FS, abs=1e-12)
    assert second.start == first.end and not corr.fits(1.023e6 * 0.2)


def test_synthetic_loops_track_to_the_closed_forms(synthetic):
    z, svs, acqs, s, ds = synthetic
    k0 = s.pull_in_ms
    bn = s.pll.bandwidth_hz
    for sv in svs:
        o = ds.sel(prn=sv.prn)
        after = o.isel(epoch=slice(k0, None))
        f_true, cn0 = sv.doppler_hz[0], 10 ** (sv.cn0_dbhz / 10)
        assert abs(float(o["refined_doppler_hz"]) - f_true) < 1.0  # the open-loop fine search
        # PLL: true phase error (Costas: modulo pi) against Kaplan's thermal jitter Bn / C/N0 (1 + 1 / (2 T C/N0))
        jitter = np.sqrt(bn / cn0 * (1 + 1 / (2 * rt.TS * cn0)))
        true_error = _wrap_half_cycle(after["pll_nco_phase"].values - (sv.carrier_phase_rad[0] + 2 * np.pi * f_true * after["time"].values))
        assert abs(np.mean(true_error)) < 2 * jitter
        assert 0.5 < np.std(true_error) / jitter < 2.0  # ~20 independent loop-error samples in 0.2 s
        # discriminator outputs: the Costas discriminator's noise (Susi 2014 eq. 10) plus the loop's jitter, 200 samples
        disc = np.sqrt(blocks.costas_variance(cn0, rt.TS) + jitter**2)
        for name in ("pll_phase_error", "mm_phase_error"):
            assert 0.8 < np.std(after[name].values) / disc < 1.25, name
        for name in ("carrier_frequency", "mm_carrier_frequency"):
            assert abs(np.mean(after[name].values) - f_true) < 0.5, name
        assert after["locked"].values.all()
        assert abs(np.mean(after["cn0"].values) - sv.cn0_dbhz) < 1.0
        # code: replica minus received code phase at each period's first sample
        received = np.mod(sv.code_phase_chips[0] + iq.code_rate_hz(f_true) * after["start_time"].values, 1023)
        dtau = np.mod(after["code_phase"].values - received + 511.5, 1023) - 511.5
        assert np.all(np.abs(dtau) < 0.1)


def test_synthetic_bit_edges_are_found_at_the_true_offset(synthetic):
    """Epoch k is the code period after the one in progress at t = 0, so with ``into`` periods of the first bit gone
    epoch k carries bit (k + 1 + into) // 20: edges on (k + 1 + into) % 20 == 0, at the truth's code epochs."""
    z, svs, acqs, s, ds = synthetic
    table = rt.summary(ds)
    k0 = s.pull_in_ms
    for sv, (*_, into) in zip(svs, TRUTH):
        row = table.sel(prn=sv.prn)
        assert int(row["bit_edge_epoch_mod20"]) == (-1 - into) % 20
        assert float(row["edge_fraction"]) == 1.0
        k = np.arange(k0, ds.sizes["epoch"])
        level = NAV[sv.prn][(k + 1 + into) // 20]
        transitions = k[1:][level[1:] != level[:-1]]
        prompt = ds.sel(prn=sv.prn)["prompt_i"].values[k0:]
        sync = bit_sync(prompt)
        np.testing.assert_array_equal(sync.edges + k0, transitions)
        assert transitions.size == int(row["n_bit_edges"]) >= 3
        first = k[(k + 1 + into) % 20 == 0][0]
        edge_time_ms = (1023 * (first + 1) - sv.code_phase_chips[0]) / iq.code_rate_hz(sv.doppler_hz[0]) / iq.MS
        assert abs(float(row["bit_edge_ms_mod20"]) - np.mod(edge_time_ms, 20)) < 1.5e3 / FS  # the sample after the code epoch


def test_refinement_resolves_the_doppler_ambiguity(synthetic):
    """Starting 300 Hz above or 400 Hz below the truth (beyond the 1-kHz prompt rate's 500-Hz ambiguity of the squared
    prompts) and 0.3 chip off, the open-loop refinement lands within 1 Hz and a few hundredths of a chip."""
    z, svs, acqs, s, ds = synthetic
    sv = svs[1]
    for df in (300.0, -400.0):
        start = replace(acqs[sv.prn], doppler_hz=sv.doppler_hz[0] + df, code_phase_chips=float(np.mod(sv.code_phase_chips[0] + 0.3, 1023)))
        fine = rt.refine_acquisition(z, FS, sv.prn, start, s.fine_search_ms)
        assert abs(fine.doppler_hz - sv.doppler_hz[0]) < 1.0
        assert abs(fine.code_phase_chips - sv.code_phase_chips[0]) < 0.05


def test_dll_pulls_a_code_error_in_at_its_loop_gain(synthetic):
    """Without the open-loop code refinement, a 0.3-chip code error decays as 0.3 exp(-K t) with the first-order loop's
    K = loop_gain(B_L, T) / T of scintrack.navigation.dll (one time constant 125 ms at B_L = 2 Hz)."""
    z, svs, acqs, s, ds = synthetic
    sv = svs[0]
    start = replace(acqs[sv.prn], code_phase_chips=float(sv.code_phase_chips[0] + 0.3))
    o = rt.track_satellite(z, FS, sv.prn, start, rt.TrackingSettings(code_passes=0), n_epochs=250)
    received = np.mod(sv.code_phase_chips[0] + iq.code_rate_hz(sv.doppler_hz[0]) * o["start_time"].values, 1023)
    dtau = np.mod(o["code_phase"].values - received + 511.5, 1023) - 511.5
    k = dll.loop_gain(s.dll_bandwidth_hz, rt.TS) / rt.TS
    expected = 0.3 * np.exp(-k * (o["time"].values - o["time"].values[0]))
    np.testing.assert_allclose(dtau, expected, atol=0.03)
    assert o["locked"].values.all()


def test_closed_loops_are_the_package_trackers(synthetic):
    """The PLL channel's NCO phases are PLL.run's on the recorded prompts (in the loop's phase frame), and the MM
    channel's posterior phases are mm_kf_kernel's on its recorded observations with the hand-over parameters:
    the closed loops run the trackers' own code."""
    z, svs, acqs, s, ds = synthetic
    for prn in ds["prn"].values:
        o = ds.sel(prn=prn)
        y = (o["pll_observation_i"].values + 1j * o["pll_observation_q"].values)[None, :]
        init = TrackInit(phase=o["pll_nco_phase"].values[:1], doppler_hz=np.array([float(o["refined_doppler_hz"])]), rate_hz_s=np.zeros(1))
        out = s.pll.run(y, init)
        np.testing.assert_array_equal(out.theta_d[0], o["pll_nco_phase"].values)
        np.testing.assert_array_equal(out.extras["discriminator"][0], o["pll_phase_error"].values)
        k0, w = s.pull_in_ms, s.mm.m2m4_window
        obs = (o["mm_observation_i"].values + 1j * o["mm_observation_q"].values)[None, k0:]
        seed = np.zeros_like(obs)
        seed[0, :w] = (o["prompt_i"].values + 1j * o["prompt_q"].values)[k0 - w : k0]
        theta = mm_kf_kernel(obs, s.mm.params(seed, rt.mm_init(obs.shape[1])))[0]
        np.testing.assert_array_equal(theta[0], o["mm_phase"].values[k0:])
        assert np.all(np.isnan(o["mm_phase"].values[:k0]))


def _capture() -> np.ndarray:
    """The Pocket SDR capture through the recording reader (its sidecar: int8 I, Q, z = I - jQ, 4 MS/s, IF 0)."""
    path = REPO / "data" / CAPTURE
    if not path.is_file():
        pytest.skip(f"the Pocket SDR capture data/{CAPTURE} is not in this checkout")
    samples, meta = read_recording(path)
    assert (meta["sample_rate_hz"], meta["intermediate_frequency_hz"]) == (FS, 0.0)
    return samples


def test_real_capture_locks_with_one_bit_edge_offset_per_satellite():
    z = _capture()
    assert z.size == 2_000_000  # 0.5 s at 4 MS/s
    acqs = {prn: acquire(z, FS, prn, n_noncoherent=10) for prn in (*CAPTURE_PRNS, ABSENT_PRN)}
    assert all(acqs[prn].detected for prn in CAPTURE_PRNS)
    s = rt.TrackingSettings()
    ds = rt.track_recording(z, FS, acqs, s)
    table = rt.summary(ds)
    after = ds.isel(epoch=slice(s.pull_in_ms, None))
    for prn in CAPTURE_PRNS:
        row = table.sel(prn=prn)
        assert float(row["edge_fraction"]) >= 0.95, prn  # every sign change after pull-in on one offset mod 20
        assert int(row["n_bit_edges"]) >= 5, prn
        assert float(row["lock_fraction"]) == 1.0, prn
        assert 35.0 < float(row["mean_cn0_dbhz"]) < 55.0, prn
        # two independent loops on the same signal agree on its frequency
        o = after.sel(prn=prn)
        assert abs(float(np.mean(o["carrier_frequency"] - o["mm_carrier_frequency"]))) < 0.5, prn
        assert float(row["mm_phase_error_std"]) < 0.35, prn
    absent = table.sel(prn=ABSENT_PRN)
    assert float(absent["lock_fraction"]) < 0.5 and float(absent["edge_fraction"]) < 0.5  # noise: no lock, no edge offset
