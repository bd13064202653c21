"""SKYDEL-like IQ recordings against the correlator-level model, via a software receiver.

Each check is re-derived here from the spec's equations (signal model of
reference notes gps-lnav-mm.md Sec. 2.2; J/S and kappa from jamming.py);
tolerances come from the sample sizes, written next to each assertion.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import signal

from scintrack.estimators import cn0 as cn0_est
from scintrack.seeding import rng_for
from scintrack.signals.gps import acquisition as acq
from scintrack.signals.gps import iq, jamming
from scintrack.signals.gps.ca_code import ca_code

FS = 12.5e6
PER_MS = 12500
T = 1e-3
N_MS = 400  # clean segment: M2M4 at 46 dB-Hz needs ~400 prompts for 0.35 dB
N_JAM = 200  # jammed segment
N0 = 1.0 / FS  # synthesise's default: unit thermal variance per sample
SEED = 20151007
#: (PRN, C/N0 dB-Hz, Doppler Hz, code phase at t=0 chips, carrier phase rad, code periods into the first bit)
CLEAN = [(1, 46.0, 1234.0, 100.3, 0.3, 0), (11, 45.0, -2710.0, 517.8, 1.1, 7), (28, 47.0, 3305.0, 903.1, -2.0, 13), (30, 46.0, -455.0, 12.6, 2.5, 19)]
ABSENT = (3, 7, 13, 19, 24, 31)
KAPPA_SS = 2.0 / (3.0 * 1.023e6)  # integral of the unit C/A spectrum squared, T_c sinc^4: the C/A-on-C/A spectral separation
ONSET_S = 0.05


def _nav_bits(prn: int) -> np.ndarray:
    return rng_for(SEED, f"test-iq/bits/{prn}", 0).choice([-1.0, 1.0], size=25)


def _svs():
    return [iq.SvSignal.constant_doppler(prn, cn0, N_MS + 1, f, cp, ph, nav_bits=_nav_bits(prn), code_periods_into_bit=into)
            for prn, cn0, f, cp, ph, into in CLEAN]


@pytest.fixture(scope="module")
def clean():
    svs = _svs()
    return svs, iq.synthesise(svs, FS, duration_s=N_MS * T, seed=SEED)


@pytest.fixture(scope="module")
def jammed():
    svs = _svs()
    kappa = jamming.spectral_separation(8e6)
    jammer = iq.Jammer(jamming.js_for_cn0_db(46.0, 15.0, kappa), onset_s=ONSET_S, reference_cn0_dbhz=46.0)  # the paper's 46 -> 15 dB-Hz
    return svs, jammer, iq.synthesise(svs, FS, duration_s=N_JAM * T, seed=SEED, jammer=jammer)


def _aligned(x, sv, n_periods=N_MS - 1, spacing=None, code_offset=0.0):
    """Correlations with the truth replica and the data bit of each code period (from the 50-bps bits directly)."""
    corr = acq.correlate(x, FS, sv.prn, np.mod(sv.code_phase_chips[0] + code_offset, 1023), sv.doppler_hz[0], sv.carrier_phase_rad[0],
                         n_periods, spacing)
    _, _, _, cp0, _, into = next(c for c in CLEAN if c[0] == sv.prn)
    period = np.arange(n_periods) + (1 if cp0 != 0 else 0)  # code period 0 is the one in progress at t = 0
    return corr, _nav_bits(sv.prn)[(period + into) // 20]


def _mai_cn0_dbhz(i: int) -> float:
    """C/N0 at satellite i's prompt: thermal N0 plus the other satellites' C/A as noise of density kappa_ss C_j."""
    lin = [10 ** (c[1] / 10) for c in CLEAN]
    return float(10 * np.log10(lin[i] / (1.0 + KAPPA_SS * (sum(lin) - lin[i]))))


def test_code_carrier_and_bits_follow_the_per_ms_truth():
    """Noise-free-like (130 dB-Hz) samples against the spec's interpolation, written independently here."""
    n_ms = 20
    rng = rng_for(SEED, "test-iq/interp", 0)
    # arbitrary per-ms truth (not continuous), with an epoch just after the start of ms 0 and exactly at the start of ms 1
    svs = [iq.SvSignal(prn, 130.0, np.r_[1022.95, 0.0, rng.uniform(0, 1023, n_ms - 2)], rng.uniform(-50, 50, n_ms),
                       rng.uniform(-4500, 4500, n_ms), rng.choice([-1.0, 1.0], n_ms)) for prn in (5, 17)]
    x = iq.synthesise(svs[:1], FS, duration_s=n_ms * T, seed=1)
    x2 = iq.synthesise(svs, FS, duration_s=n_ms * T, seed=1)
    n = np.arange(n_ms * PER_MS)
    k, u = n // PER_MS, (n % PER_MS) / FS

    def expected(sv):
        theta = sv.code_phase_chips[k] + 1.023e6 * (1 + sv.doppler_hz[k] / 1575.42e6) * u
        bit = np.where(theta < 1023, sv.data_bits[k], sv.data_bits[np.minimum(k + 1, n_ms - 1)])
        amp = np.sqrt(N0 * 10 ** (sv.cn0_dbhz / 10))
        return amp * ca_code(sv.prn)[np.floor(theta).astype(int) % 1023] * bit * np.exp(1j * (sv.carrier_phase_rad[k] + 2 * np.pi * sv.doppler_hz[k] * u)), theta

    s1, theta = expected(svs[0])
    s2, theta2 = expected(svs[1])
    assert np.abs(s1[0]) > 800  # A = 894 against unit noise
    # thermal noise has unit variance, so |noise| < 6 except with probability e^-36; a wrong chip, bit or phase gives ~A
    at_edge = (np.abs(theta - np.rint(theta)) < 1e-6) | (np.abs(theta2 - np.rint(theta2)) < 1e-6)
    assert np.all((np.abs(x - s1) < 6) | at_edge[: x.size])
    assert np.all((np.abs(x2 - s1 - s2) < 6) | at_edge)
    assert np.count_nonzero(at_edge) < 5
    # the same seed gives the same thermal noise whatever the satellites
    np.testing.assert_allclose(x2 - s2, x, atol=0.05)


def test_acquisition_finds_present_prns_and_rejects_absent(clean):
    svs, x = clean
    bins = np.arange(-5000.0, 5001.0, 500.0)
    for sv in svs:
        found = acq.acquire(x, FS, sv.prn, bins, n_coherent_ms=1, n_noncoherent=5)
        err = (found.code_phase_chips - sv.code_phase_chips[0] + 511.5) % 1023 - 511.5
        assert abs(err) < 0.5, (sv.prn, found)
        assert abs(found.doppler_hz - sv.doppler_hz[0]) <= 500.0, (sv.prn, found)
        # 46 dB-Hz over 1 ms: peak/noise ~ 40 against a noise-only maximum of ~3-4 x the mean of 5 summed cells
        assert found.peak_ratio > 3.0, (sv.prn, found)
    for prn in (5, 17):
        # noise only: the largest and second largest of ~260k cells differ by a few per cent
        assert acq.acquire(x, FS, prn, bins, n_noncoherent=5).peak_ratio < 2.0


def test_prompts_and_m2m4_match_the_configured_cn0(clean):
    svs, x = clean
    moments, m2m4 = [], []
    for i, sv in enumerate(svs):
        corr, bits = _aligned(x, sv)
        wiped = corr.prompt * bits
        k = wiped.size
        amp = np.sqrt(N0 * 10 ** (sv.cn0_dbhz / 10))
        noise = (N0 / T) * 10 ** ((sv.cn0_dbhz - _mai_cn0_dbhz(i)) / 10)  # N0_eff / T incl. the other satellites
        # the mean of Re(P d) is A, with std sqrt(noise / 2k) (~0.8 % of A)
        assert abs(np.mean(wiped.real) - amp) < 5 * np.sqrt(noise / (2 * k)), sv.prn
        # the aligned, bit-wiped prompt is A + n: var(I) + var(Q) estimates N0_eff / T, relative std sqrt(1/k) = 7 %
        residual = np.var(wiped.real) + np.var(wiped.imag)
        moments.append(10 * np.log10(np.mean(wiped.real) ** 2 / residual / T))
        pd, pn = cn0_est.m2m4(corr.prompt)
        m2m4.append(float(cn0_est.to_dbhz(cn0_est.cn0_from_powers(pd, pn, T))))
    configured = np.array([c[1] for c in CLEAN])
    # per satellite: moments std ~0.22 dB, M2M4 (k = 399 at SNR 40) ~0.35 dB; the other satellites' C/A lowers the
    # prompt's C/N0 by 0.1-0.35 dB (see the off-PRN floor test), so the 4-satellite means sit ~0.1-0.3 dB low
    assert np.all(np.abs(np.array(moments) - configured) < 1.0), moments
    assert np.all(np.abs(np.array(m2m4) - configured) < 1.0), m2m4
    assert abs(np.mean(np.array(moments) - configured)) < 0.6
    assert abs(np.mean(np.array(m2m4) - configured)) < 0.6


def test_off_prn_noise_floor_is_n0_over_t(clean):
    svs, x = clean
    floors = np.concatenate([acq.correlate(x, FS, prn, 0.0, 0.0, 0.0, N_MS - 1).prompt for prn in ABSENT])
    lin = sum(10 ** (c[1] / 10) for c in CLEAN)
    expected = N0 / T * (1 + KAPPA_SS * lin)  # thermal + all four satellites' C/A (11 % here)
    # ~2400 complex samples: relative std 2 %; the satellites' part is deterministic per code pair, so allow 4.5 sigma
    assert abs(np.mean(np.abs(floors) ** 2) / expected - 1) < 4.5 / np.sqrt(floors.size)


def test_early_late_follow_the_triangle(clean):
    svs, x = clean
    sv = svs[2]
    amp = np.sqrt(N0 * 10 ** (sv.cn0_dbhz / 10))
    sigma = np.sqrt(N0 / T * 1.1 / (2 * (N_MS - 1)))  # std of a mean of Re over N_MS - 1 periods
    for offset, (e, p, late) in {0.0: (0.5, 1.0, 0.5), 0.25: (0.25, 0.75, 0.75)}.items():
        # local code ahead by `offset` chips: dtau = +offset, so I_X ~ A R(dtau + o_X), o_E = +0.5, o_L = -0.5
        corr, bits = _aligned(x, sv, spacing=1.0, code_offset=offset)
        for out, level in ((corr.early, e), (corr.prompt, p), (corr.late, late)):
            assert abs(np.mean((out * bits).real) / amp - level) < 5 * sigma / amp + 0.005, (offset, level)


def test_jammer_filter_and_spectrum():
    taps = iq.jammer_taps(8e6, 0.0, FS)
    assert len(taps) % 2 == 1 and np.allclose(taps, taps[::-1])  # type-I linear phase
    assert abs(iq.equivalent_noise_bandwidth(taps, FS) - 8e6) < 1e3
    f, h = signal.freqz(taps, worN=4096, fs=FS, whole=True)
    f = np.where(f >= FS / 2, f - FS, f)
    gain = 20 * np.log10(np.abs(h) / np.abs(h[0]))
    assert np.ptp(gain[np.abs(f) < 3.8e6]) < 0.05 and gain[np.abs(f) > 4.6e6].max() < -55
    jammer = iq.Jammer(60.0, reference_cn0_dbhz=46.0)
    x = iq.synthesise([], FS, duration_s=0.1, seed=SEED, jammer=jammer)
    power = 10 ** ((60 + 46) / 10) * N0  # J = (J/S) S, S = N0 10^(46/10)
    # ~1.25e6 samples of 8-MHz noise: relative std of the mean power < 0.2 %; thermal noise (1) is known
    assert abs(np.mean(np.abs(x.astype(np.complex128)) ** 2) - 1.0 - power) < 0.01 * power
    f, p = signal.welch(x, fs=FS, nperseg=2048, return_onesided=False, detrend=False)
    level = 10 * np.log10(p / np.mean(p[np.abs(f) < 3.5e6]))
    # ~1200 averaged segments: 0.13 dB per bin; thermal floor 37 dB below the jammer's density
    assert np.all(np.abs(level[np.abs(f) < 3.5e6]) < 1.0)
    assert np.all(level[np.abs(f) > 5e6] < -20.0)
    offset = iq.synthesise([], FS, duration_s=0.05, seed=SEED, jammer=iq.Jammer(60.0, bandwidth_hz=2e6, offset_hz=-3e6, reference_cn0_dbhz=46.0))
    f, p = signal.welch(offset, fs=FS, nperseg=2048, return_onesided=False, detrend=False)
    assert np.sum(p[np.abs(f + 3e6) < 1.1e6]) > 0.99 * np.sum(p)


def test_jammed_segment_reaches_the_effective_cn0(clean, jammed):
    svs, jammer, x = jammed
    _, x_clean = clean
    onset = int(round(ONSET_S * FS))
    assert np.array_equal(x[:onset], x_clean[:onset])  # the jammer has its own stream and starts at the onset
    kappa = jammer.kappa()
    power = 10 ** ((jammer.js_db + 46.0) / 10) * N0
    assert abs(np.mean(np.abs((x[onset:] - x_clean[onset:x.size]).astype(np.complex128)) ** 2) / power - 1) < 0.01
    residuals, amps = [], []
    for sv in svs:
        corr, bits = _aligned(x, sv, N_JAM - 1)
        wiped = corr.prompt * bits
        before = corr.start_index + corr.n_samples <= onset
        amps.append(np.mean(wiped.real[before]))  # C is unchanged by the jammer: estimated from the ~49 clean periods
        after = wiped[corr.start_index >= onset]
        residuals.append(after - np.mean(after.real))  # A + n with A constant: the residual is the noise (I and Q)
    offs = [acq.correlate(x, FS, prn, 0.0, 0.0, 0.0, N_JAM - 1) for prn in ABSENT]
    noise_samples = np.concatenate(residuals + [c.prompt[c.start_index >= onset] for c in offs])
    noise = np.mean(np.abs(noise_samples) ** 2)  # N0_eff / T, from the PRNs' residuals and off-PRN prompts
    expected_noise = N0 / T * (1 + kappa * power / N0)
    assert abs(noise / expected_noise - 1) < 4 / np.sqrt(noise_samples.size)  # ~1500 complex samples: 2.6 % std
    estimated = 10 * np.log10(np.array(amps) ** 2 / noise / T)
    js_each = jammer.js_db + 46.0 - np.array([sv.cn0_dbhz for sv in svs])  # J/C of each satellite
    effective = jamming.effective_cn0_dbhz([sv.cn0_dbhz for sv in svs], js_each, kappa)
    # amplitude (1.6 %) and noise (2.6 %) errors: ~0.17 dB per satellite
    assert np.all(np.abs(estimated - effective) < 1.0), (estimated, effective)
    assert abs(np.mean(estimated - effective)) < 0.5


def test_int16_round_trip_and_sidecar(tmp_path, clean, jammed):
    svs, x = clean
    _, jammer, xj = jammed
    side = iq.make_sidecar(svs, fs=FS, duration_s=N_JAM * T, seed=SEED, gps_week=1865, gps_seconds_of_week=345600.0, jammer=jammer)
    meta = iq.write_recording(tmp_path / "jammed.bin", xj, side)
    assert meta["jammer"]["js_db"] == jammer.js_db and abs(meta["jammer"]["filter"]["equivalent_noise_bandwidth_hz"] - 8e6) < 1e3
    assert all(abs(s["effective_cn0_dbhz_after_onset"] - (15.0 + s["cn0_dbhz"] - 46.0)) < 0.01 for s in meta["satellites"])
    path = tmp_path / "clean.dat"
    meta = iq.write_recording(path, x, iq.make_sidecar(svs, fs=FS, duration_s=N_MS * T, seed=SEED, gps_week=1865, gps_seconds_of_week=345600.0))
    assert path.stat().st_size == 4 * x.size and meta["clipped_values"] == 0
    back, read_meta = iq.read_recording(path)
    assert read_meta == meta and read_meta["jammer"] is None and read_meta["centre_frequency_hz"] == 1575.42e6
    assert back.dtype == np.complex64 and back.size == x.size
    scale = meta["scale"]
    assert np.isclose(np.abs(x.view(np.float32)).max() * scale, 0.9 * 32767, rtol=1e-6)
    # half an LSB, plus float32 rounding of scale * x (< 2^-23 x 32767 x 2 = 0.008 LSB)
    assert np.max(np.abs(back.view(np.float32) - x.view(np.float32))) <= 0.51 / scale
    # uniform rounding error, variance 1/12 LSB^2 per component
    theory = 10 * np.log10(np.mean(np.abs(x.astype(np.complex128)) ** 2) * scale**2 / (2 / 12))
    assert abs(meta["quantisation_snr_db"] - theory) < 0.1 and meta["quantisation_snr_db"] > 70
    # a corrupted byte, a truncated file and a damaged sidecar are refused
    data = bytearray(path.read_bytes())
    data[1001] ^= 0x01
    path.write_bytes(bytes(data))
    with pytest.raises(ValueError, match="sha256"):
        iq.read_recording(path)
    path.write_bytes(bytes(data[:-4]))
    with pytest.raises(ValueError, match="bytes"):
        iq.read_recording(path)
    sidecar = iq.sidecar_path(path)
    sidecar.write_text(json.dumps({k: v for k, v in meta.items() if k != "scale"}))
    with pytest.raises(ValueError, match="scale"):
        iq.read_recording(path)
    with pytest.raises(ValueError, match="must end in"):
        iq.write_recording(tmp_path / "x.raw", x, meta)
    # a fixed scale clips, and says how much
    fixed = iq.write_recording(tmp_path / "hot.bin", x, meta, scale=32767 / 2.0)
    assert fixed["clipped_values"] == np.count_nonzero(np.abs(np.rint(x.view(np.float32) * np.float32(32767 / 2.0))) > 32767) > 0


def test_same_seed_same_bytes_and_chunking_does_not_matter(tmp_path, monkeypatch):
    svs = [iq.SvSignal.constant_doppler(1, 46.0, 26, 800.0, 3.0)]
    jammer = iq.Jammer(40.0, onset_s=0.0123)
    kwargs = dict(duration_s=0.025, jammer=jammer)
    side = iq.make_sidecar(svs, fs=FS, duration_s=0.025, seed=7, gps_week=1865, gps_seconds_of_week=0.0, jammer=jammer)
    a = iq.write_recording(tmp_path / "a.bin", iq.synthesise(svs, FS, seed=7, **kwargs), side)
    b = iq.write_recording(tmp_path / "b.bin", iq.synthesise(svs, FS, seed=7, **kwargs), side)
    assert (tmp_path / "a.bin").read_bytes() == (tmp_path / "b.bin").read_bytes() and a["sha256"] == b["sha256"]
    reference = iq.synthesise(svs, FS, seed=7, **kwargs)
    assert not np.array_equal(iq.synthesise(svs, FS, seed=8, **kwargs), reference)
    monkeypatch.setattr(iq, "CHUNK_MS", 3)  # chunk edges inside the jammer: the FIR must run on continuously
    rechunked = iq.synthesise(svs, FS, seed=7, **kwargs)
    onset = int(np.ceil(0.0123 * FS))
    assert np.array_equal(rechunked[:onset], reference[:onset])  # signal + thermal noise: bit for bit
    # the jammer's FFT convolution rounds differently with other block lengths (float32, ~1e-7 of its rms);
    # a break in the filter state at a chunk edge would be an error of the order of the rms itself
    rms = np.sqrt(np.mean(np.abs(reference[onset:]) ** 2))
    assert np.max(np.abs(rechunked - reference)) < 1e-5 * rms


def test_bad_inputs_are_refused():
    sv = iq.SvSignal.constant_doppler(1, 46.0, 10, 0.0, 0.0)
    with pytest.raises(ValueError, match="code_phase_chips"):
        iq.SvSignal(1, 46.0, [1023.0], [0.0], [0.0], [1.0])
    with pytest.raises(ValueError, match="data_bits"):
        iq.SvSignal(1, 46.0, [0.0], [0.0], [0.0], [0.0])
    with pytest.raises(ValueError, match="covers 10 ms"):
        iq.synthesise([sv], FS, duration_s=0.02, seed=1)
    with pytest.raises(ValueError, match="multiple of 1 kHz"):
        iq.synthesise([sv], 12.5e6 + 1.0, duration_s=0.001, seed=1)
    with pytest.raises(ValueError, match="reference_cn0_dbhz"):
        iq.synthesise([sv, iq.SvSignal.constant_doppler(2, 40.0, 10, 0.0, 0.0)], FS, duration_s=0.001, seed=1, jammer=iq.Jammer(40.0))
    with pytest.raises(ValueError, match="does not fit"):
        iq.jammer_taps(8e6, 3e6, FS)
    with pytest.raises(ValueError, match="samples"):
        acq.correlate(np.zeros(1000, np.complex64), FS, 1, 0.0, 0.0, 0.0, 1)
