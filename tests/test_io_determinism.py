"""Content hashes, atomic NetCDF round trips, seeding and dataset versions."""

from __future__ import annotations

import numpy as np
import xarray as xr

from scintrack.data.synthetic import csm_training_dataset, csm_training_params, csm_training_version
from scintrack.io import content_hash, open_dataset, write_netcdf
from scintrack.seeding import rng_for

CONFIG = {
    "seed": 7,
    "sampling": {"ts": 0.01, "nspa": 8},
    "csm": {"output": "average", "warmup_s": 1.0},
    "ar_training": {"s4": [0.5], "tau0": [0.2, 0.4], "duration_s": 20.0, "trials": 2},
}


def test_two_generations_give_identical_content_hashes():
    params = csm_training_params(CONFIG, 0.5)
    a = csm_training_dataset(params)
    b = csm_training_dataset(params)
    assert content_hash(a) == content_hash(b)
    other = csm_training_dataset({**params, "seed": 8})
    assert content_hash(other) != content_hash(a)


def test_version_follows_parameters():
    params = csm_training_params(CONFIG, 0.5)
    assert csm_training_version(params) == csm_training_version(dict(params))
    assert csm_training_version({**params, "duration_s": 21.0}) != csm_training_version(params)


def test_netcdf_round_trip_keeps_content_hash(tmp_path):
    ds = csm_training_dataset(csm_training_params(CONFIG, 0.5))
    ds.attrs["note"] = "attributes do not enter the content hash"
    path = tmp_path / "sub" / "x.nc"
    digest = write_netcdf(ds, path)
    back = open_dataset(path)
    assert back.attrs["content_sha256"] == digest == content_hash(back)
    assert not list(path.parent.glob("*.part"))


def test_lazy_open_reads_a_variable_when_used_with_the_eager_values(tmp_path):
    """What the figure and table jobs open: nothing read at open, a variable read when used, and every
    value (and the content hash) the eager open's; a missing file is the same one-line error."""
    import pytest

    from scintrack.io import DatasetReadError

    path = tmp_path / "x.nc"
    write_netcdf(csm_training_dataset(csm_training_params(CONFIG, 0.5)), path)
    eager, lazy = open_dataset(path), open_dataset(path, lazy=True)
    name = next(iter(lazy.data_vars))
    assert not any(v._in_memory for v in lazy.data_vars.values())
    lazy[name].values  # noqa: B018 - read it
    assert lazy[name].variable._in_memory and not all(v._in_memory for v in lazy.data_vars.values())
    assert content_hash(lazy) == content_hash(eager) == eager.attrs["content_sha256"]
    xr.testing.assert_identical(lazy.load(), eager)
    lazy.close()
    with pytest.raises(DatasetReadError, match="no such file"):
        open_dataset(tmp_path / "missing.nc", lazy=True)


def test_content_hash_sees_a_single_changed_value():
    ds = xr.Dataset({"a": ("x", np.arange(5.0))})
    changed = ds.copy(deep=True)
    changed["a"].values[3] += 1e-12
    assert content_hash(ds) != content_hash(changed)


def test_seed_streams_are_independent_and_reproducible():
    a = rng_for(1, "name", 0).standard_normal(4)
    np.testing.assert_array_equal(a, rng_for(1, "name", 0).standard_normal(4))
    assert not np.allclose(a, rng_for(1, "name", 1).standard_normal(4))
    assert not np.allclose(a, rng_for(1, "other", 0).standard_normal(4))


def test_dataset_version_follows_generator_code():
    from scintrack import codeversion
    from scintrack.data.synthetic import GENERATOR_VERSION
    from scintrack.data.versioning import code_version, dataset_version

    v1 = code_version("g", "scintrack.data.synthetic")
    assert v1 == "g-" + codeversion.code_version(["scintrack.data.synthetic"], length=12)
    assert GENERATOR_VERSION.endswith(v1[2:])  # the CSM dataset versions use exactly this mechanism
    v2 = code_version("g", "scintrack.data.surrogate")
    assert v2 != v1
    assert dataset_version("gen", v1, {"a": 1}) != dataset_version("gen", v2, {"a": 1})
    assert dataset_version("gen", v1, {"a": 1}) != dataset_version("gen", v1, {"a": 2})


def test_fault_injection_holds_outputs_not_the_code_cache(tmp_path, monkeypatch):
    """SCINTRACK_HOLD_BEFORE_RENAME delays the writes of outputs (the kill-and-resume test kills a job there), not
    the code-version cache that Snakemake's own process writes while it builds the DAG (each of those writes held
    delayed the first job of a fresh folder by ~80 s)."""
    from scintrack import atomic, codeversion

    slept = []
    monkeypatch.setattr(atomic.time, "sleep", slept.append)
    monkeypatch.setenv("SCINTRACK_HOLD_BEFORE_RENAME", "7.5")
    atomic.atomic_bytes(tmp_path / "out.txt", "x")
    assert slept == [7.5] and (tmp_path / "out.txt").read_text() == "x"
    monkeypatch.setenv("SCINTRACK_CODE_CACHE", str(tmp_path / "cache.json"))
    codeversion.clear_caches()
    codeversion.clear_disk_cache_memory()
    try:
        codeversion.code_version(["scintrack.progress"])
    finally:
        codeversion.clear_caches()
        codeversion.clear_disk_cache_memory()
    assert (tmp_path / "cache.json").is_file() and slept == [7.5]
