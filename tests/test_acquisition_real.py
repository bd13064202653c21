"""Acquisition: the statistic's noise-only distribution, multi-period coherent integration, real-IF input, and the real captures.

The real-capture tests assert what the files themselves show (several
satellites clear the threshold, the same ones in both halves of the 0.5-s
capture at the same Doppler, the declared I/Q sign agrees with the code
Doppler, the declared IF puts the satellites near zero Doppler), not numbers
copied from a run.
"""

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from scintrack.signals.gps import acquisition as acq
from scintrack.signals.gps import iq
from scintrack.signals.gps.ca_code import ca_code
from scintrack.signals.recording import read_recording

REPO = Path(__file__).resolve().parents[1]
REAL = REPO / "data" / "real"
POCKET_IQ = REAL / "pocketsdr" / "L1_20211202_084700_4MHz_IQ.bin"
POCKET_IF = REAL / "pocketsdr" / "L1_20211125_004000_12MHz_I.bin"
GSOC = REAL / "gnss-sdr" / "GSoC_CTTC_capture_2012_07_26_4Msps_4ms.dat"


def test_threshold_inverts_the_false_alarm_formula():
    # one exponential cell: P(X > g) = exp(-g)
    assert acq.detection_threshold(0.01, 1, 1) == pytest.approx(-math.log(0.01))
    for p_fa, cells, k in [(0.05, 5115, 2), (1e-3, 724000, 1), (1e-6, 188000, 4)]:
        gamma = acq.detection_threshold(p_fa, cells, k)
        assert acq.false_alarm_probability(gamma, cells, k) == pytest.approx(p_fa, rel=1e-6)
        # more cells or more blocks need a higher threshold
        assert acq.detection_threshold(p_fa, 10 * cells, k) > gamma < acq.detection_threshold(p_fa, cells, k + 1)


def test_doppler_bins_default_step_is_two_thirds_of_the_bin_width():
    bins = acq.doppler_bins(12e3, None, 10)
    assert np.allclose(np.diff(bins), 2 / (3 * 0.010)) and bins[0] <= -12e3 and bins[-1] >= 12e3 and 0.0 in bins


def _noise_searches(n_searches: int, fs: float, bins, k: int, seed: int) -> list:
    rng = np.random.default_rng(seed)
    n = int(round(fs * 1e-3)) * k
    out = []
    for _ in range(n_searches):
        x = (rng.standard_normal(n) + 1j * rng.standard_normal(n)).astype(np.complex64)
        out.append(acq.acquire(x, fs, 7, bins, n_coherent_ms=1, n_noncoherent=k, p_fa=0.05))
    return out


def test_noise_only_false_alarm_rate_matches_the_stated_probability():
    # one sample per chip and Doppler bins 1/T apart: the cells are independent, so the rate is the stated one
    n = 400
    found = _noise_searches(n, 1.023e6, np.arange(-2, 3) * 1e3, 2, seed=11)
    assert found[0].n_cells == 1023 * 5 and found[0].n_blocks == 2
    hits = sum(a.detected for a in found)
    lo, hi = stats.binom.ppf([0.0005, 0.9995], n, 0.05)
    assert lo <= hits <= hi, hits
    # the same searches at P_fa = 1e-3: zero or very few
    strict = acq.detection_threshold(1e-3, found[0].n_cells, 2)
    assert sum(a.statistic > strict for a in found) <= stats.binom.ppf(0.9995, n, 1e-3)
    # no C/N0 is reported for a search that found nothing
    assert all(math.isnan(a.cn0_dbhz) for a in found if not a.detected)


def test_noise_only_rate_is_at_most_the_stated_one_on_an_oversampled_fine_grid():
    n = 200
    found = _noise_searches(n, 4e6, acq.doppler_bins(1e3, None, 1), 1, seed=12)
    assert sum(a.detected for a in found) <= stats.binom.ppf(0.9995, n, 0.05)


def _synthetic(prn: int, cn0: float, doppler: float, code_phase: float, n_ms: int, fs: float, seed: int = 5):
    sv = iq.SvSignal.constant_doppler(prn, cn0, n_ms + 1, doppler, code_phase)
    return iq.synthesise([sv], fs, duration_s=n_ms * 1e-3, seed=seed)


def test_ten_ms_coherent_statistic_is_large_for_a_signal_and_not_one_for_noise():
    fs, doppler = 4e6, 1000.0  # on a bin of the 10-ms grid
    x = _synthetic(5, 45.0, doppler, 300.25, 20, fs)
    bins = acq.doppler_bins(2e3, None, 10)
    found = acq.acquire(x, fs, 5, bins, n_coherent_ms=10, n_noncoherent=2)
    assert found.detected and found.statistic > 20 * found.threshold
    # one copy of the peak per code period: the second peak is noise, far below the peak
    assert found.peak_ratio > 20
    assert abs(found.doppler_hz - doppler) <= np.diff(bins)[0]
    assert abs((found.code_phase_chips - 300.25 + 511.5) % 1023 - 511.5) < 0.5
    # (Lambda/K - 1)/T at 45 dB-Hz, up to the half-sample code straddle (<= 1.2 dB) and noise
    assert 45.0 - 1.5 < found.cn0_dbhz < 45.0 + 0.5
    absent = acq.acquire(x, fs, 6, bins, n_coherent_ms=10, n_noncoherent=2)
    assert not absent.detected and absent.peak_ratio != 1.0 and 1.0 < absent.peak_ratio < 2.0


def test_code_doppler_is_followed_across_noncoherent_blocks():
    # 4.5 kHz for 0.4 s: the code drifts by 1.2 chips (4.6 samples); unaligned blocks would smear the peak
    fs, doppler = 4e6, 4500.0
    x = _synthetic(9, 40.0, doppler, 100.0, 400, fs)
    found = acq.acquire(x, fs, 9, [doppler], n_coherent_ms=10, n_noncoherent=40)
    # up to 1.2 dB of code straddle at 4 MHz
    assert found.n_blocks == 40 and 40.0 - 1.5 < found.cn0_dbhz < 40.0 + 0.5
    # code phase at the first sample (the drift is undone, not averaged into it)
    assert abs((found.code_phase_chips - 100.0 + 511.5) % 1023 - 511.5) < 0.5


def test_real_if_samples_are_down_converted_at_if_plus_doppler():
    fs, f_if, doppler = 12e6, 3e6, -1200.0
    x = _synthetic(12, 45.0, doppler, 700.5, 10, fs)
    t = np.arange(x.size) / fs
    real = (np.sqrt(2) * np.real(x * np.exp(2j * np.pi * f_if * t))).astype(np.float32)
    bins = acq.doppler_bins(3e3, None, 10)
    found = acq.acquire(real, fs, 12, bins, n_coherent_ms=10, n_noncoherent=1, intermediate_frequency_hz=f_if)
    assert found.detected and abs(found.doppler_hz - doppler) <= np.diff(bins)[0]
    assert abs((found.code_phase_chips - 700.5 + 511.5) % 1023 - 511.5) < 0.5
    # 20 kHz off the IF, it finds nothing; at 0 Hz the wiped real noise would not be circular, so that is refused
    assert not acq.acquire(real, fs, 12, bins, n_coherent_ms=10, n_noncoherent=1, intermediate_frequency_hz=f_if + 20e3).detected
    with pytest.raises(ValueError, match="intermediate frequency"):
        acq.acquire(real, fs, 12, bins, n_coherent_ms=10, n_noncoherent=1)


def test_the_cross_correlation_bound_covers_the_codes():
    codes = np.array([ca_code(p) for p in range(1, 33)], dtype=float)
    spectra = np.fft.fft(codes, axis=1)
    n = np.arange(1023)
    worst = 0.0
    for khz in (0, 1, -3, 5):
        rotated = np.fft.fft(codes[:8] * np.exp(2j * np.pi * khz * n / 1023), axis=1)
        for i in range(8):
            p = np.abs(np.fft.ifft(rotated[i] * np.conj(spectra), axis=1)) ** 2 / 1023**2
            p[i] = 0.0
            worst = max(worst, p.max())
    assert 10 * np.log10(worst) <= acq.CROSS_CORRELATION_DB + 1e-9


# ----------------------------------------------------------------------------- the real captures


@pytest.fixture(scope="module")
def pocket_halves():
    x, meta = read_recording(POCKET_IQ)
    half = x.size // 2
    kwargs = dict(n_coherent_ms=10, n_noncoherent=1, doppler_span_hz=6e3, p_fa=1e-3)
    return [acq.search(part, meta["sample_rate_hz"], range(1, 33), **kwargs) for part in (x[:half], x[half:])]


def test_pocket_sdr_capture_same_satellites_in_both_halves(pocket_halves):
    first, second = ({a.prn: a for a in half} for half in pocket_halves)
    step = 2 / (3 * 0.010)
    for found in (first, second):
        detected = [a for a in found.values() if a.detected]
        assert len(detected) >= 4, detected
        assert all(a.statistic > a.threshold and 30.0 < a.cn0_dbhz < 55.0 for a in detected)
    clear = {p for half in (first, second) for p, a in half.items() if a.detected and a.statistic > 2 * a.threshold}
    assert len(clear) >= 4
    for prn in clear:  # a satellite clearly present in one half is found in the other, at the same Doppler
        assert first[prn].detected and second[prn].detected, prn
    for prn in first:
        if first[prn].detected and second[prn].detected:
            assert abs(first[prn].doppler_hz - second[prn].doppler_hz) <= step + 1e-6, prn


def test_pocket_sdr_declared_iq_sign_agrees_with_the_code_doppler(pocket_halves):
    # over the whole 0.5 s the code drifts by f/1540 chips per second; the search undoes the drift
    # that the carrier Doppler implies, which adds the blocks up only if the carrier sign is right
    x, meta = read_recording(POCKET_IQ)
    strongest = sorted((a for a in pocket_halves[0] if a.detected and abs(a.doppler_hz) > 1500), key=lambda a: -a.statistic)[:2]
    assert strongest
    for a in strongest:
        near = a.doppler_hz + np.arange(-2, 3) * 2 / (3 * 0.010)
        right = acq.acquire(x, 4e6, a.prn, near, n_coherent_ms=10, n_noncoherent=None)
        wrong = acq.acquire(np.conj(x), 4e6, a.prn, -near, n_coherent_ms=10, n_noncoherent=None)
        assert right.statistic > 1.5 * wrong.statistic, (a.prn, right.statistic, wrong.statistic)


def test_pocket_sdr_real_if_capture_at_its_declared_if():
    table = acq.recording_table(POCKET_IF, n_coherent_ms=5, n_noncoherent=1, doppler_span_hz=6e3)
    assert list(table.columns) == list(acq.TABLE_COLUMNS) and table.attrs["intermediate_frequency_hz"] == 3e6
    detected = table[table["detected"]]
    assert len(detected) >= 4
    assert (detected["statistic"] > detected["threshold"]).all()
    # the same search 20 kHz off the declared IF finds no satellite
    x, meta = read_recording(POCKET_IF)
    off = acq.search(x, meta["sample_rate_hz"], detected["prn"], n_coherent_ms=5, n_noncoherent=1, doppler_span_hz=6e3,
                     intermediate_frequency_hz=3.02e6)
    assert not any(a.detected for a in off)


def test_gnss_sdr_capture_needs_a_wide_doppler_search_and_noncoherent_blocks():
    x, meta = read_recording(GSOC)
    wide = acq.search(x, meta["sample_rate_hz"], range(1, 33), n_coherent_ms=1, n_noncoherent=None, doppler_span_hz=15e3)
    assert wide[0].n_blocks == 4  # as many 1-ms blocks as the 4-ms file holds
    detected = [a for a in wide if a.detected]
    assert len(detected) >= 3
    # the receiver clock offset puts satellites beyond the +-5 kHz of a receiver at rest
    beyond = [a for a in detected if abs(a.doppler_hz) > 6e3]
    assert beyond
    narrow = acq.search(x, meta["sample_rate_hz"], [a.prn for a in beyond], n_coherent_ms=1, n_noncoherent=None, doppler_span_hz=5e3)
    assert not any(a.detected for a in narrow)
