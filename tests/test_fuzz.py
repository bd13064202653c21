"""Fuzzing the readers and the config validator with hypothesis: valid data or one clear InputError line.

Each target gets random bytes and valid inputs mutated (truncated, bytes
flipped, NaN/inf injected, time made non-monotonic, units changed, variables
and dims renamed, keys dropped, types changed).  For every example the reader
either returns data that satisfies its documented invariants, or raises an
:class:`~scintrack.errors.InputError` whose message is one non-empty line
naming the file (or the config key / the input); any other exception fails.

Runs are deterministic (``derandomize=True``, no example database) and small
enough for CI: the ``max_examples`` of each target is in :data:`RUNS`; a
longer local campaign: ``SCINTRACK_FUZZ_SCALE=20 pytest tests/test_fuzz.py``.
"""

from __future__ import annotations

import itertools
import json
import os
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st
from hypothesis.control import currently_in_test_context

from scintrack.config import load_config, validate_config
from scintrack.data.traces import load_trace
from scintrack.errors import ConfigError, InputError
from scintrack.signals.gps import ephemeris, iq, lnav, message

REPO = Path(__file__).resolve().parents[1]
SCHEMA = REPO / "workflow" / "schemas" / "config.schema.yaml"
RINEX = REPO / "data" / "ephemerides" / "brdc2800.15n"  # the committed broadcast file (as tests/test_ephemeris.py)

#: max_examples per target (the whole file runs in well under 25 s on a loaded 2-core machine)
RUNS = {
    "trace_bytes": 40, "trace_mutated": 120, "rinex": 50, "iq": 80,
    "lnav_random": 40, "lnav_mutated": 40, "lnav_malformed": 40, "config": 60, "config_bytes": 40,
}
SCALE = float(os.environ.get("SCINTRACK_FUZZ_SCALE", "1"))
_COUNTER = itertools.count()


def fuzz(target: str):
    return settings(max_examples=max(1, round(RUNS[target] * SCALE)), deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture, HealthCheck.data_too_large])


def assert_clear(exc: BaseException, *names: str) -> str:
    """``exc`` is an InputError whose message is one non-empty line naming one of ``names``."""
    assert isinstance(exc, InputError), f"{type(exc).__name__} is not an InputError: {exc!r}"
    text = str(exc)
    assert text.strip() and "\n" not in text and "\r" not in text, repr(text)
    assert any(n in text for n in names), f"message names none of {names}: {text}"
    if currently_in_test_context():
        event(f"refused: {type(exc).__name__}")  # outcome counts: pytest --hypothesis-show-statistics
    return text


def _fresh(folder: Path, name: str) -> Path:
    """A new path per example (xarray caches open files by name)."""
    sub = folder / f"x{next(_COUNTER)}"
    sub.mkdir()
    return sub / name


def _mutate_bytes(data: bytes, draw) -> bytes:
    """Truncated at a random offset and/or some bytes replaced."""
    out = bytearray(data)
    for _ in range(draw(st.integers(0, 4))):
        if out:
            out[draw(st.integers(0, len(out) - 1))] = draw(st.integers(0, 255))
    if draw(st.booleans()):
        out = out[: draw(st.integers(0, len(out)))]
    return bytes(out)


# ----------------------------------------------------------------------------- real-trace loader

BANDS = ["L1", "L2"]
TS = 0.01
N = 200
SUFFIXES = [".nc", ".npz", ".csv", ".mat"]


def _trace_arrays(seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    out = {"time": 500.0 + np.arange(N) * TS}
    for b in BANDS:
        a = np.abs(1 + 0.3 * rng.standard_normal(N))
        out[f"amplitude_{b}"] = a / np.sqrt(np.mean(a**2))
        out[f"phase_{b}"] = np.cumsum(0.05 * rng.standard_normal(N))
    return out


def _write_trace(arrays: dict, path: Path, units: dict, dims: dict) -> None:
    if path.suffix == ".npz":
        np.savez(path, **arrays)
    elif path.suffix == ".csv":
        import pandas as pd

        longest = max((np.size(v) for v in arrays.values()), default=0)
        pd.DataFrame({k: pd.Series(np.ravel(v)) for k, v in arrays.items()}, index=range(longest)).to_csv(path, index=False)
    elif path.suffix == ".mat":
        from scipy.io import savemat

        savemat(path, arrays)
    else:
        ds = xr.Dataset()
        for k, v in arrays.items():
            v = np.asarray(v)
            shape_dims = (dims.get(k, "n"),) if v.ndim == 1 else tuple(f"{dims.get(k, 'n')}{i}" for i in range(v.ndim))
            ds[k] = (shape_dims, v)
            if k in units:
                ds[k].attrs["units"] = units[k]
        ds.to_netcdf(path)


VARS = ["time"] + [f"{q}_{b}" for b in BANDS for q in ("amplitude", "phase")]
MUTATIONS = ["none", "nan", "inf", "swap_time", "dup_time", "time_ms", "units", "rename", "drop", "shorten", "strings",
             "two_d", "db", "degrees", "wrapped", "negative", "empty", "complex", "huge", "scalar", "dim_rename", "int"]


@st.composite
def mutated_trace(draw):
    arrays = _trace_arrays(draw(st.integers(0, 3)))
    units = {"time": "s", "phase_L1": "rad", "amplitude_L2": "1"}
    dims: dict[str, str] = {}
    kinds = draw(st.lists(st.sampled_from(MUTATIONS), min_size=1, max_size=3))
    for kind in kinds:
        name = draw(st.sampled_from(VARS))
        if name not in arrays or np.ndim(arrays[name]) == 0:  # gone or already made a scalar
            continue
        v = np.asarray(arrays[name])
        i = draw(st.integers(0, max(v.size - 2, 0)))
        if kind in ("nan", "inf") and v.size and v.dtype.kind == "f":
            v = v.copy()
            v.flat[i] = np.nan if kind == "nan" else draw(st.sampled_from([np.inf, -np.inf]))
        elif kind in ("swap_time", "dup_time") and np.ndim(arrays.get("time")) == 1 and np.size(arrays["time"]) > 2 and np.asarray(arrays["time"]).dtype.kind == "f":
            t = np.asarray(arrays["time"], dtype=float).copy()
            i = min(i, t.size - 2)
            t[i], t[i + 1] = (t[i + 1], t[i]) if kind == "swap_time" else (t[i], t[i])
            arrays["time"] = t
            continue
        elif kind == "time_ms" and "time" in arrays:
            arrays["time"] = np.asarray(arrays["time"]) * 1000.0
            units["time"] = "ms"
            continue
        elif kind == "units":
            units[name] = draw(st.sampled_from(["ms", "deg", "dB", "cycles", "", "seconds since 2015-10-07", "days since 1970-01-01"]) | st.text(max_size=8))
        elif kind == "rename":
            arrays[draw(st.sampled_from(["t", "Time", "amp_L1", "phase L2", "x"]))] = arrays.pop(name)
            continue
        elif kind == "drop":
            arrays.pop(name)
            continue
        elif kind == "shorten":
            v = v[: draw(st.integers(0, v.size))]
        elif kind == "strings":
            v = v.astype(str)
        elif kind == "two_d" and v.size % 2 == 0:
            v = v.reshape(2, -1)
        elif kind == "db" and v.dtype.kind == "f":
            v = 20 * np.log10(np.abs(v) + 1e-12)
        elif kind == "degrees" and v.dtype.kind == "f":
            v = np.degrees(v) * 50
        elif kind == "wrapped" and v.dtype.kind == "f":
            v = np.angle(np.exp(1j * 40 * v))
        elif kind == "negative" and v.dtype.kind == "f":
            v = -v
        elif kind == "empty":
            v = v[:0]
        elif kind == "complex" and v.dtype.kind == "f":
            v = v.astype(complex)
        elif kind == "huge" and v.dtype.kind == "f":
            with np.errstate(over="ignore"):
                v = v * draw(st.sampled_from([1e300, -1e300, 1e-300]))
        elif kind == "scalar":
            v = np.asarray(v.flat[0] if v.size else 0.0)
        elif kind == "dim_rename":
            dims[name] = draw(st.sampled_from(["m", "time", "band", "n2"]))
        elif kind == "int":
            v = np.round(v).astype(np.int64) if v.dtype.kind == "f" and np.all(np.abs(v) < 2**62) else v
        arrays[name] = v
    return arrays, units, dims, kinds


def _check_trace(ds: xr.Dataset) -> None:
    """The loader's documented invariants (docs/data.md)."""
    assert ds["amplitude"].dims == ("band", "time") and ds["phase"].dims == ("band", "time")
    assert list(ds["band"].values) == BANDS
    t = ds["time"].values
    a, p = ds["amplitude"].values, ds["phase"].values
    assert t.size >= 2 and t[0] == 0.0
    assert np.all(np.isfinite(t)) and np.all(np.isfinite(a)) and np.all(np.isfinite(p))
    assert np.all(np.abs(np.diff(t) - TS) <= 0.01 * TS + 1e-12)
    assert np.all(a >= 0) and np.all((np.mean(a**2, axis=1) >= 0.5) & (np.mean(a**2, axis=1) <= 2.0))
    assert np.all(np.abs(np.diff(p, axis=1)) <= 1.5 * np.pi)


def _load_trace_or_clear(path: Path) -> None:
    try:
        ds = load_trace(path, BANDS, TS, event="e", source="real")
    except Exception as exc:  # noqa: BLE001 (any non-InputError fails in assert_clear)
        assert_clear(exc, str(path))
    else:
        _check_trace(ds)
        event("loaded")


@fuzz("trace_bytes")
@given(data=st.binary(max_size=600), suffix=st.sampled_from(SUFFIXES + [".h5", ""]))
def test_trace_random_bytes(tmp_path_factory, data, suffix):
    path = _fresh(tmp_path_factory.getbasetemp(), "event" + suffix)
    path.write_bytes(data)
    _load_trace_or_clear(path)


@fuzz("trace_mutated")
@given(case=mutated_trace(), suffix=st.sampled_from(SUFFIXES), data=st.data())
def test_trace_mutated_files(tmp_path_factory, case, suffix, data):
    arrays, units, dims, kinds = case
    path = _fresh(tmp_path_factory.getbasetemp(), "event" + suffix)
    try:
        _write_trace(arrays, path, units, dims)
    except Exception:  # noqa: BLE001 (the container cannot hold this mutation: nothing to read)
        event("not writable")
        return
    if data.draw(st.integers(0, 3)) == 0:
        path.write_bytes(_mutate_bytes(path.read_bytes(), data.draw))
    _load_trace_or_clear(path)


def test_trace_valid_files_load(tmp_path):
    """The unmutated files load in every container (the fuzzer's mutations start from valid data)."""
    for suffix in SUFFIXES:
        path = tmp_path / f"ok{suffix}"
        _write_trace(_trace_arrays(0), path, {"time": "s"}, {})
        _check_trace(load_trace(path, BANDS, TS, event="e", source="real"))


# ----------------------------------------------------------------------------- RINEX navigation reader

def _rinex_lines() -> list[str]:
    """Header and the first six broadcast records (8 lines each) of the real file: small and quick to parse."""
    lines = RINEX.read_text().splitlines(keepends=True)
    end = next(i for i, line in enumerate(lines) if "END OF HEADER" in line) + 1
    return lines[: end + 6 * 8]


@st.composite
def mutated_rinex(draw):
    lines = list(_rinex_lines())
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["flip", "delete", "duplicate", "garbage_field", "blank_field", "swap"]))
        i = draw(st.integers(0, len(lines) - 1))
        line = lines[i]
        if kind == "flip" and line:
            j = draw(st.integers(0, len(line) - 1))
            lines[i] = line[:j] + draw(st.sampled_from(list("0123456789 DE.-+xG\t"))) + line[j + 1 :]
        elif kind == "delete":
            del lines[i]
        elif kind == "duplicate":
            lines.insert(i, line)
        elif kind in ("garbage_field", "blank_field"):
            j = draw(st.integers(0, 3)) * 19 + 3
            fill = "garbage".rjust(19) if kind == "garbage_field" else " " * 19
            lines[i] = (line[:j] + fill + line[j + 19 :]) if len(line) > j else line
        elif kind == "swap" and i + 1 < len(lines):
            lines[i], lines[i + 1] = lines[i + 1], lines[i]
    data = "".join(lines).encode("ascii", errors="replace")
    if draw(st.booleans()):
        data = _mutate_bytes(data, draw)
    return data


def _check_ephemerides(ephs: list) -> None:
    assert ephs, "load returned no data set instead of raising"
    keys = [(e.prn, e.week, e.t_oc) for e in ephs]
    assert keys == sorted(keys)
    names = {n for table in lnav.FIELDS.values() for n in table}
    for e in ephs:
        assert 1 <= e.prn <= 32 and names <= set(e.fields)
        for table in lnav.FIELDS.values():  # every field fits the LNAV message (raises ValueError otherwise)
            for n, f in table.items():
                lnav.raw_value(e.fields[n], f, n)
        assert np.isfinite(e.transmit_time) and np.isfinite(e.fit_hours)


@fuzz("rinex")
@given(data=st.one_of(mutated_rinex(), st.binary(max_size=400)))
def test_rinex_mutated_files(tmp_path_factory, data):
    path = _fresh(tmp_path_factory.getbasetemp(), "brdc2800.15n")
    path.write_bytes(data)
    try:
        ephs = ephemeris.load(path)
    except Exception as exc:  # noqa: BLE001
        assert_clear(exc, str(path))
    else:
        _check_ephemerides(ephs)
        event("loaded")
    try:
        header = ephemeris.read_header(path)
    except Exception as exc:  # noqa: BLE001
        assert_clear(exc, str(path))
    else:
        assert len(header.alpha) == 4 and len(header.beta) == 4
        assert all(np.isfinite([*header.alpha, *header.beta, header.a0, header.a1]))


# ----------------------------------------------------------------------------- IQ recording and sidecar

def _write_iq(folder: Path) -> tuple[Path, dict]:
    rng = np.random.default_rng(1)
    n = 64
    samples = (rng.standard_normal(n) + 1j * rng.standard_normal(n)).astype(np.complex64)
    sidecar = {"sample_rate_hz": 1000.0, "centre_frequency_hz": iq.L1_HZ, "intermediate_frequency_hz": 0.0, "gps_week": 1865,
               "gps_seconds_of_week": 0.0, "duration_s": n / 1000.0, "satellites": [], "jammer": None, "seed": 1}
    path = _fresh(folder, "clean.bin")
    return path, iq.write_recording(path, samples, sidecar)


JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**70), 2**70) | st.floats(allow_nan=False) | st.text(max_size=10),
    lambda children: st.lists(children, max_size=3) | st.dictionaries(st.text(max_size=6), children, max_size=3),
    max_leaves=6,
)


@fuzz("iq")
@given(data=st.data(), target=st.sampled_from(["data", "sidecar_bytes", "sidecar_value", "sidecar_drop", "sidecar_json", "missing"]))
def test_iq_recording_mutated(tmp_path_factory, data, target):
    path, meta = _write_iq(tmp_path_factory.getbasetemp())
    side = iq.sidecar_path(path)
    if target == "data":
        path.write_bytes(_mutate_bytes(path.read_bytes(), data.draw))
    elif target == "sidecar_bytes":
        side.write_bytes(_mutate_bytes(side.read_bytes(), data.draw))
    elif target == "sidecar_value":
        meta[data.draw(st.sampled_from(sorted(meta)))] = data.draw(JSON_VALUES)
        side.write_text(json.dumps(meta))
    elif target == "sidecar_drop":
        meta.pop(data.draw(st.sampled_from(sorted(meta))))
        side.write_text(json.dumps(meta))
    elif target == "sidecar_json":
        side.write_text(json.dumps(data.draw(JSON_VALUES)))
    else:
        data.draw(st.sampled_from([path, side])).unlink()
    try:
        samples, got = iq.read_recording(path)
    except Exception as exc:  # noqa: BLE001
        assert_clear(exc, path.name)
    else:
        event("loaded")
        assert samples.dtype == np.complex64 and samples.ndim == 1
        assert samples.size == got["n_samples"] and np.all(np.isfinite(samples.view(np.float32)))


def test_iq_sidecar_nested_too_deep(tmp_path):
    path, _ = _write_iq(tmp_path)
    iq.sidecar_path(path).write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(InputError) as info:
        iq.read_recording(path)
    assert_clear(info.value, path.name)


# ----------------------------------------------------------------------------- LNAV decoder

def _check_decoded(subframes: list, n: int) -> None:
    """decode_message's contract: subframes at increasing offsets inside the stream, 10 parity verdicts each."""
    offsets = [s.offset for s in subframes]
    assert offsets == sorted(offsets) and all(0 <= k and k + lnav.SUBFRAME_BITS <= n for k in offsets)
    for s in subframes:
        assert isinstance(s, message.DecodedSubframe) and len(s.parity_ok) == 10
        assert 0 <= s.subframe_id <= 7 and 0 <= s.t0 < 604800 and isinstance(s.fields, dict)


@pytest.fixture(scope="module")
def lnav_stream() -> np.ndarray:
    """Four valid subframes 1-3 / 1 (header + zero fields) with parity chained, as transmitted."""
    fields = {name: 0 for table in lnav.FIELDS.values() for name in table}
    out, tail = [], (0, 0)
    for t0 in (0, 6, 12, 30):
        sent = lnav.encode_subframe(lnav.source_bits(t0, fields), *tail)
        tail = (sent[-2], sent[-1])
        out += sent
    return np.array(out, dtype=np.int8)


@fuzz("lnav_random")
@given(bits=st.lists(st.integers(0, 1), max_size=2000))
def test_lnav_random_bits(bits):
    _check_decoded(message.decode_message(bits), len(bits))


@fuzz("lnav_mutated")
@given(data=st.data())
def test_lnav_mutated_stream(lnav_stream, data):
    bits = lnav_stream.copy()
    for k in data.draw(st.lists(st.integers(0, bits.size - 1), max_size=40)):
        bits[k] ^= 1
    start = data.draw(st.integers(0, bits.size))
    bits = bits[start : start + data.draw(st.integers(0, bits.size))]
    if data.draw(st.booleans()):
        bits = 1 - bits
    decoded = message.decode_message(bits)
    _check_decoded(decoded, bits.size)
    if bits.size == lnav_stream.size and np.array_equal(bits, lnav_stream):
        assert len(decoded) == 4 and all(s.ok for s in decoded)


def test_lnav_clean_stream_decodes(lnav_stream):
    decoded = message.decode_message(lnav_stream)
    assert [s.subframe_id for s in decoded] == [1, 2, 3, 1] and all(s.ok for s in decoded)
    assert [s.t0 for s in decoded] == [0, 6, 12, 30]


def _with_bad_value(case) -> list:
    bits, bad, at = case
    return bits[:at] + [bad] + bits[at:]


MALFORMED_BITS = st.one_of(
    st.tuples(st.lists(st.integers(0, 1), max_size=400),
              st.sampled_from([-1, 2, 3, 255, -128]) | st.floats().filter(lambda x: x not in (0.0, 1.0)),
              st.integers(0, 400)).map(_with_bad_value),
    st.lists(st.text(max_size=2), min_size=1, max_size=50),
    st.lists(st.lists(st.integers(0, 1), min_size=2, max_size=2), min_size=1, max_size=50),
    st.just(None), st.integers(), st.text(max_size=20),
)


@fuzz("lnav_malformed")
@given(bits=MALFORMED_BITS)
def test_lnav_malformed_input(bits):
    """Anything but a 1-D stream of 0/1 is refused with one line naming the input (``bits``)."""
    with pytest.raises(InputError) as info:
        message.decode_message(bits)
    assert_clear(info.value, "bits")


# ----------------------------------------------------------------------------- config validator

def _paths(node, prefix=()):
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, (*prefix, i))


BASES = {
    "config": load_config([REPO / "config" / "config.yaml"]),
    "smoke": load_config([REPO / "config" / "config.yaml", REPO / "config" / "smoke.yaml"]),
}
BASE_PATHS = {name: [p for p in _paths(cfg) if p] for name, cfg in BASES.items()}
RANDOM_VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(-(10**6), 10**6), st.floats(), st.text(max_size=12),
    st.lists(st.integers(-5, 5) | st.floats(-10, 10) | st.text(max_size=4), max_size=3),
    st.dictionaries(st.text(max_size=5), st.integers(), max_size=2),
)


def _at(node, path):
    for k in path:
        node = node[k]
    return node


@fuzz("config")
@given(data=st.data(), base=st.sampled_from(sorted(BASES)))
def test_config_mutations(data, base):
    import copy

    config = copy.deepcopy(BASES[base])
    for _ in range(data.draw(st.integers(1, 2))):
        paths = [p for p in _paths(config) if p]
        path = data.draw(st.sampled_from(paths))
        try:
            parent = _at(config, path[:-1])
        except (KeyError, IndexError, TypeError):
            continue
        kind = data.draw(st.sampled_from(["drop", "value", "scale", "unknown", "type"]))
        key = path[-1]
        if kind == "drop":
            del parent[key]
        elif kind == "value":
            parent[key] = data.draw(RANDOM_VALUES)
        elif kind == "scale" and isinstance(parent[key], int | float) and not isinstance(parent[key], bool):
            parent[key] = parent[key] * data.draw(st.sampled_from([-1, 0, 0.5, 2, 1e6, float("nan"), float("inf")]))
        elif kind == "unknown" and isinstance(parent[key], dict):
            parent[key][data.draw(st.sampled_from(["typo", "pll_bandwith_hz", "x"]))] = data.draw(RANDOM_VALUES)
        elif kind == "type":
            v = parent[key]
            parent[key] = str(v) if not isinstance(v, str) else [v]
    try:
        validate_config(config, SCHEMA)
    except Exception as exc:  # noqa: BLE001
        assert isinstance(exc, ConfigError), f"{type(exc).__name__} is not a ConfigError: {exc!r}"
        text = assert_clear(exc, "at '")
        assert re.search(r"at '[^']+'", text), text
    else:
        event("valid")


@fuzz("config_bytes")
@given(data=st.one_of(st.binary(max_size=300), st.text(max_size=300).map(str.encode),
                      st.sampled_from(["config.yaml", "smoke.yaml"]).flatmap(
                          lambda name: st.integers(0, 4000).map(lambda k: (REPO / "config" / name).read_bytes()[:k]))))
@example(data=b"[" * 2000)  # deep nesting: the YAML parser's recursion limit
@example(data=b"\x80")  # not UTF-8
def test_load_config_random_bytes(tmp_path_factory, data):
    path = _fresh(tmp_path_factory.getbasetemp(), "overlay.yaml")
    path.write_bytes(data)
    try:
        config = load_config([path])
    except Exception as exc:  # noqa: BLE001
        assert isinstance(exc, ConfigError), f"{type(exc).__name__} is not a ConfigError: {exc!r}"
        assert_clear(exc, str(path))
    else:
        assert isinstance(config, dict)
        yaml.safe_dump(config)  # plain YAML data
