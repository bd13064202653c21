"""The IQ recordings of the jammed GPS scenario, cross-checked against the scenario truth and the correlator-level model.

A software receiver correlates the recorded samples with a local replica at
the truth's code phase, Doppler and carrier phase: the prompts must have the
truth's carrier phase, the SNR the correlator model gives (a^2 / (2 sigma^2)
= C/N0 T), and under the jammer the effective C/N0 that J/S and the spectral
separation coefficient predict, each within 1 dB.

The recording holds what the correlator-level model leaves out: the other
satellites' codes.  Their cross-correlation adds, per interfering satellite,
about C_j T / 1023 to the noise of a 1-ms prompt (the mean Gold-code
cross-correlation power), 0.5 dB of C/N0 for three satellites at 46 dB-Hz and
nothing measurable under the jammer; the clean check includes it.
"""

import numpy as np
import pytest
from test_gps_dataset import small_config

from scintrack.data.gps_iq import iq_params, segment_seed
from scintrack.data.gps_iq_build import record, sv_signal, write
from scintrack.data.gps_jamming_build import build
from scintrack.data.gps_jamming_spec import gps_jamming_params
from scintrack.project import project_file
from scintrack.signals.gps import acquisition, iq

T = 1e-3
LENGTH_S = 0.4
CHUNK_MS = 50  # the replica is re-anchored to the truth every 50 ms (its Doppler is held constant within a chunk)


@pytest.fixture(scope="module")
def scenario(tmp_path_factory):
    cfg = small_config(duration_s=10.0, uploads=[])
    cfg["gps_jamming"]["jammer"] = {**cfg["gps_jamming"]["jammer"], "onset_s": 5.0}
    cfg["gps_jamming"]["iq"] = {"sample_rate_hz": 12.5e6, "clean_start_s": 1.0, "jammed_start_s": 6.0, "length_s": LENGTH_S}
    params = gps_jamming_params(cfg)
    ds = build(params, project_file(params["ephemerides"]))
    p = iq_params(cfg)
    folder = tmp_path_factory.mktemp("iq")
    written = write(record(ds, p), {"clean": folder / "clean.bin", "jammed": folder / "jammed.bin"})
    segments = {name: iq.read_recording(folder / f"{name}.bin") for name in ("clean", "jammed")}
    return ds, p, segments, written


def _prompts(ds, k, samples, start_s):
    """Bit-wiped prompts of satellite k with the replica at the truth, chunk by chunk; a chunk's first full code period is epoch n + 1."""
    out = []
    fs = 12.5e6
    rt = ds["receive_time"].isel(sv=k).values
    per = int(round(CHUNK_MS * T * fs))
    for j in range(int(round(LENGTH_S / T)) // CHUNK_MS):
        t = start_s + j * CHUNK_MS * T
        sv = sv_signal(ds, k, t, 1)
        chunk = samples[j * per : (j + 2) * per]
        corr = acquisition.correlate(chunk, fs, sv.prn, float(sv.code_phase_chips[0]), float(sv.doppler_hz[0]), float(sv.carrier_phase_rad[0]), CHUNK_MS - 1)
        n = int(np.searchsorted(rt, t, side="right")) - 1
        out.append(corr.prompt * ds["bit"].isel(sv=k).values[n + 1 : n + CHUNK_MS])
    return np.concatenate(out)


def _with_mai(ds):
    """Clean C/N0 with the other satellites' mean cross-correlation power as extra noise."""
    cn0 = 10 ** (float(ds.attrs["cn0_clean_dbhz"]) / 10)
    others = ds.sizes["sv"] - 1
    return -10 * np.log10(1 / cn0 + others * T / 1023)


def test_clean_prompts_have_the_truth_phase_and_the_model_snr(scenario):
    ds, p, segments, _ = scenario
    samples, side = segments["clean"]
    for k in range(ds.sizes["sv"]):
        z = _prompts(ds, k, samples, side["segment_start_s"])
        mean = z.mean()
        assert abs(np.angle(mean)) < 0.15  # carrier phase and sign of the truth (0.15 rad)
        snr = abs(mean) ** 2 / np.var(z)  # = a^2 / (2 sigma^2) = C/N0 T in the correlator model
        cn0 = 10 * np.log10(snr / T)
        assert abs(cn0 - _with_mai(ds)) < 1.0, (k, cn0, _with_mai(ds))


def test_jammed_noise_floor_gives_the_effective_cn0(scenario):
    ds, p, segments, written = scenario
    assert written["clean"]["scale"] == written["jammed"]["scale"]  # one gain for both segments
    want = float(ds.attrs["cn0_jammed_dbhz"])
    for k in range(ds.sizes["sv"]):
        clean = _prompts(ds, k, segments["clean"][0], 1.0)
        jammed = _prompts(ds, k, segments["jammed"][0], 6.0)
        c = abs(clean.mean()) ** 2  # carrier power: the jammer does not change it (fixed gain)
        cn0 = 10 * np.log10(c / (np.var(jammed) * T))
        assert abs(cn0 - want) < 1.0, (k, cn0, want)


def test_acquisition_finds_the_truth(scenario):
    ds, _, segments, _ = scenario
    samples, side = segments["clean"]
    for k in range(ds.sizes["sv"]):
        sv = sv_signal(ds, k, side["segment_start_s"], 1)
        bins = np.arange(-5000.0, 5001.0, 250.0)
        acq = acquisition.acquire(samples, 12.5e6, sv.prn, bins, n_coherent_ms=1, n_noncoherent=5)
        err = (acq.code_phase_chips - sv.code_phase_chips[0] + 511.5) % 1023 - 511.5
        assert abs(err) < 0.5 and abs(acq.doppler_hz - sv.doppler_hz[0]) <= 125.0


def test_sidecar_describes_the_recording(scenario):
    ds, p, segments, written = scenario
    for name, (samples, side) in segments.items():
        assert side["sample_rate_hz"] == 12.5e6 and side["format"].startswith("int16")
        assert [s["prn"] for s in side["satellites"]] == [int(x) for x in ds["prn"].values]
        assert side["segment"] == name and side["scenario_dataset"] == ds.attrs["dataset_version"]
        assert side["seed"] == segment_seed(p["seed"], name)
        assert samples.size == int(round(LENGTH_S * 12.5e6))
    assert segments["clean"][1]["jammer"] is None and segments["jammed"][1]["jammer"]["js_db"] == pytest.approx(54.14)
