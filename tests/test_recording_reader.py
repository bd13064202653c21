"""The one reader of raw recordings: every sample format round-trips, a mis-described file gives one line, the committed captures read.

Each format is written here byte by byte with numpy (not with the reader's
own tables), so a wrong dtype, byte order, I/Q order or sign convention in the
reader changes the samples it returns.
"""

import hashlib
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from scintrack.data.registry import read_registry
from scintrack.errors import InputError
from scintrack.signals import recording
from scintrack.signals.gps import iq

REPO = Path(__file__).resolve().parents[1]
REAL = {
    "real_pocketsdr_l1_4mhz_iq": 0.5,
    "real_pocketsdr_l1_12mhz_if": 0.1,
    "real_gnss_sdr_gsoc_4ms": 0.004,
}


def _write(folder: Path, name: str, payload: bytes, n: int, **fields) -> Path:
    path = folder / name
    path.write_bytes(payload)
    meta = {"sample_rate_hz": 4e6, "intermediate_frequency_hz": 0.0, "centre_frequency_hz": 1575.42e6, "n_samples": n, "scale": 1.0,
            "sha256": hashlib.sha256(payload).hexdigest(), "start_time": "2021-12-01T08:47:00Z", "time_scale": "UTC",
            "source": "test", **fields}
    recording.sidecar_path(path).write_text(json.dumps(meta))
    return path


def _one_line(exc: BaseException, *names: str) -> str:
    text = str(exc)
    assert isinstance(exc, recording.IQFormatError) and isinstance(exc, InputError)
    assert text.strip() and "\n" not in text, text
    for name in names:
        assert name in text, (name, text)
    return text


# I/Q formats: (format name, how numpy stores one component)
IQ_FORMATS = [("int8 interleaved IQ", "i1"), ("int16 interleaved IQ little-endian", "<i2"), ("complex64 little-endian", "<f4")]
REAL_FORMATS = [("int8 real", "i1"), ("int16 real little-endian", "<i2"), ("float32 real little-endian", "<f4")]


@pytest.mark.parametrize("fmt,dtype", IQ_FORMATS)
@pytest.mark.parametrize("sign", [1, -1])
def test_iq_formats_round_trip_with_their_sign_convention(tmp_path, fmt, dtype, sign):
    rng = np.random.default_rng(7)
    i = rng.integers(-100, 101, 500)
    q = rng.integers(-100, 101, 500)
    interleaved = np.empty(1000)
    interleaved[0::2], interleaved[1::2] = i, q
    path = _write(tmp_path, "rec.bin", interleaved.astype(dtype).tobytes(), 500, format=fmt, iq_sign=sign, scale=4.0)
    samples, meta = recording.read_recording(path)
    assert samples.dtype == np.complex64 and samples.shape == (500,)
    np.testing.assert_array_equal(samples, ((i + sign * 1j * q) / 4.0).astype(np.complex64))
    assert meta["iq_sign"] == sign and meta["format"] == fmt


@pytest.mark.parametrize("fmt,dtype", REAL_FORMATS)
def test_real_formats_round_trip_as_real_samples(tmp_path, fmt, dtype):
    values = np.random.default_rng(3).integers(-120, 121, 777)
    path = _write(tmp_path, "rec.bin", values.astype(dtype).tobytes(), 777, format=fmt, sample_rate_hz=12e6,
                  intermediate_frequency_hz=3e6, scale=2.0)
    samples, _ = recording.read_recording(path)
    assert samples.dtype == np.float32 and not np.iscomplexobj(samples)
    np.testing.assert_array_equal(samples, (values / 2.0).astype(np.float32))


def test_synthetic_writer_fills_the_common_fields_and_reads_back(tmp_path):
    x = np.exp(1j * np.arange(4000) * 0.01)
    side = iq.make_sidecar([], fs=2.046e6, duration_s=4000 / 2.046e6, seed=1, gps_week=1865, gps_seconds_of_week=86400.5)
    meta = iq.write_recording(tmp_path / "rec.bin", x, side)
    samples, back = recording.read_recording(tmp_path / "rec.bin")
    assert back == meta and back["iq_sign"] == 1 and back["time_scale"] == "GPS"
    # GPS week 1865 starts on Sunday 2015-10-04 (GPS time, no leap seconds)
    assert back["start_time"] == "2015-10-05T00:00:00.500000"
    assert np.max(np.abs(samples - x)) < 1e-4
    assert iq.read_recording is recording.read_recording and iq.IQFormatError is recording.IQFormatError


def _good(tmp_path: Path) -> Path:
    data = np.arange(-50, 50, dtype="<i2")  # 50 I/Q pairs
    return _write(tmp_path, "rec.bin", data.tobytes(), 50, format="int16 interleaved IQ little-endian", iq_sign=1, duration_s=50 / 4e6)


def test_a_good_file_reads(tmp_path):
    samples, _ = recording.read_recording(_good(tmp_path))
    assert samples.size == 50


def test_size_that_is_not_whole_samples_or_shorter_than_declared(tmp_path):
    path = _good(tmp_path)
    payload = path.read_bytes()
    path.write_bytes(payload[:-1])
    with pytest.raises(recording.IQFormatError) as info:
        recording.read_recording(path)
    _one_line(info.value, "rec.bin", "not a whole number", "format")
    path.write_bytes(payload[:-4])  # one whole I/Q pair less
    with pytest.raises(recording.IQFormatError) as info:
        recording.read_recording(path)
    _one_line(info.value, "rec.bin", "shorter", "n_samples")
    path.write_bytes(payload + payload[:4])
    with pytest.raises(recording.IQFormatError) as info:
        recording.read_recording(path)
    _one_line(info.value, "longer", "n_samples")
    path.write_bytes(payload[:-2] + b"\x00\x01")  # same size, changed byte
    with pytest.raises(recording.IQFormatError) as info:
        recording.read_recording(path)
    _one_line(info.value, "rec.bin", "sha256")


@pytest.mark.parametrize(
    "change,field",
    [
        ({"format": "int12 packed"}, "format"),
        ({"format": None}, "format"),
        ({"sample_rate_hz": "4 MHz"}, "sample_rate_hz"),
        ({"sample_rate_hz": -4e6}, "sample_rate_hz"),
        ({"intermediate_frequency_hz": 3e6}, "intermediate_frequency_hz"),  # beyond fs/2 for I/Q at 4 MHz
        ({"iq_sign": 0}, "iq_sign"),
        ({"iq_sign": True}, "iq_sign"),
        ({"scale": 0}, "scale"),
        ({"n_samples": 50.0}, "n_samples"),
        ({"start_time": "1 Dec 2021"}, "start_time"),
        ({"time_scale": "TAI"}, "time_scale"),
        ({"source": ""}, "source"),
        ({"duration_s": 1.0}, "duration_s"),
        ({"sha256": "abc"}, "sha256"),
        ({"centre_frequency_hz": 10**400}, "centre_frequency_hz"),
    ],
)
def test_a_wrong_field_is_named(tmp_path, change, field):
    path = _good(tmp_path)
    side = recording.sidecar_path(path)
    meta = json.loads(side.read_text())
    meta.update(change)
    side.write_text(json.dumps(meta))
    with pytest.raises(recording.IQFormatError) as info:
        recording.read_recording(path)
    _one_line(info.value, "rec.bin", field)


@pytest.mark.parametrize("field", ["format", "sample_rate_hz", "intermediate_frequency_hz", "n_samples", "sha256", "iq_sign", "start_time"])
def test_a_missing_field_is_named(tmp_path, field):
    path = _good(tmp_path)
    side = recording.sidecar_path(path)
    meta = json.loads(side.read_text())
    del meta[field]
    side.write_text(json.dumps(meta))
    with pytest.raises(recording.IQFormatError) as info:
        recording.read_recording(path)
    _one_line(info.value, "rec.bin", field)


def test_real_samples_need_an_if_inside_the_first_nyquist_zone(tmp_path):
    path = _write(tmp_path, "if.bin", np.ones(10, "i1").tobytes(), 10, format="int8 real", sample_rate_hz=12e6, intermediate_frequency_hz=0.0)
    with pytest.raises(recording.IQFormatError) as info:
        recording.read_recording(path)
    _one_line(info.value, "if.bin", "intermediate_frequency_hz")


def test_missing_sidecar_or_data(tmp_path):
    path = _good(tmp_path)
    recording.sidecar_path(path).unlink()
    with pytest.raises(recording.IQFormatError) as info:
        recording.read_recording(path)
    _one_line(info.value, "rec.bin.json", "no sidecar")
    with pytest.raises(recording.IQFormatError) as info:
        recording.read_recording(tmp_path / "nothing.bin")
    _one_line(info.value, "nothing.bin")


def test_a_script_reports_one_error_line_and_keeps_the_file(tmp_path):
    path = _good(tmp_path)
    payload = path.read_bytes()[:-3]
    path.write_bytes(payload)
    code = ("from scintrack.errors import install_script_hook; install_script_hook()\n"
            "from scintrack.signals.recording import read_recording\n"
            f"read_recording({str(path)!r})\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 1 and len(lines) == 1 and lines[0].startswith("error: ") and "rec.bin" in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr and path.read_bytes() == payload


@pytest.mark.parametrize("name", sorted(REAL))
def test_committed_real_recordings_read_and_match_the_registry(name):
    entry = read_registry(REPO / "data" / "registry.yaml")["datasets"][name]
    path = REPO / entry["path"]
    assert REPO / entry["sidecar"] == recording.sidecar_path(path)
    samples, meta = recording.read_recording(path)  # checks the sidecar's sha256
    assert meta["sha256"] == entry["sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    # the size alone fixes the duration (the Pocket SDR readme's "100 ms" for the IQ file is not what it holds)
    assert samples.size / meta["sample_rate_hz"] == pytest.approx(REAL[name])
    licence = [p for p in path.parent.iterdir() if "licen" in p.name.lower()]
    assert licence, f"no licence file beside {path}"
    if "pocketsdr" in name:
        # 2-bit ADC: every component takes one of the four levels
        levels = np.unique(np.concatenate([samples.real, samples.imag]) if np.iscomplexobj(samples) else samples)
        assert set(levels.tolist()) <= {-3.0, -1.0, 1.0, 3.0}
