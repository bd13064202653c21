"""Atomic NetCDF/text writes, content hashes and provenance attributes.

* :func:`write_netcdf` writes to a temporary file in the target folder and
  renames it, so a crash never leaves a half-written file where a complete one
  is expected.
* :func:`content_hash` hashes the *data values* (names, dims, dtypes, bytes of
  every variable and coordinate), not the file bytes, which depend on the
  netCDF/HDF5 library versions.  Attributes are excluded, so provenance that
  changes from run to run (git commit, paths) does not alter it.
* :func:`provenance` gives the attributes every result carries; its
  ``config_sha256`` covers the config values the result depends on.

numpy and xarray are imported inside the functions that use them: the
workflow imports this module whenever Snakemake builds the DAG (for
:func:`hash_object` and :func:`git_state`), which must not load them.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import subprocess
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from . import __version__
from .atomic import atomic_bytes, atomic_write
from .errors import InputError, one_line

if TYPE_CHECKING:
    import xarray as xr


def sha256_file(path: str | os.PathLike, chunk: int = 1 << 20) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(chunk), b""):
            h.update(block)
    return h.hexdigest()


def canonical_json(obj: Any) -> str:
    """JSON with sorted keys and no whitespace variation (for hashing)."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=_json_default)


def pretty_json(obj: Any) -> str:
    """Indented JSON with sorted keys (numpy scalars and arrays allowed)."""
    return json.dumps(obj, sort_keys=True, indent=2, default=_json_default) + "\n"


def _json_default(obj: Any) -> Any:
    import numpy as np

    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot serialise {type(obj).__name__}")


def hash_object(obj: Any) -> str:
    return hashlib.sha256(canonical_json(obj).encode()).hexdigest()


def content_hash(ds: xr.Dataset) -> str:
    """sha256 of a Dataset's values (variables and coordinates, not attributes)."""
    import numpy as np

    h = hashlib.sha256()
    for name in sorted(map(str, ds.variables)):
        var = ds.variables[name]
        values = np.ascontiguousarray(var.values)
        if values.dtype.kind in "US":
            payload = canonical_json(values.tolist()).encode()
        elif values.dtype.kind == "O":
            payload = canonical_json([str(v) for v in values.ravel()]).encode()
        else:
            payload = values.astype(values.dtype.newbyteorder("<"), copy=False).tobytes()
        header = canonical_json({"name": name, "dims": list(var.dims), "shape": list(values.shape), "dtype": values.dtype.str.lstrip("<>|=")})
        h.update(header.encode())
        h.update(payload)
    return h.hexdigest()


def git_state(cwd: str | os.PathLike | None = None) -> dict[str, Any]:
    """Git commit and dirty flag of the working tree ("unknown" outside git)."""
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=cwd, capture_output=True, text=True, check=True, timeout=10
        ).stdout.strip()
        dirty = bool(
            subprocess.run(
                ["git", "status", "--porcelain", "--untracked-files=no"],
                cwd=cwd, capture_output=True, text=True, check=True, timeout=10,
            ).stdout.strip()
        )
        return {"git_commit": commit, "git_dirty": dirty}
    except (OSError, subprocess.SubprocessError):
        return {"git_commit": "unknown", "git_dirty": True}


#: in a workflow job: what ran (``ran``: code version and git state at the job's start) and the check every
#: output passes first (``confirm``); set by :func:`scintrack.jobcode.begin`, empty outside a job
JOB: dict[str, Any] = {}


def confirm_job_code() -> None:
    """In a workflow job, check that its code is still the code its rule was planned with (nothing to do outside one)."""
    if JOB:
        JOB["confirm"]()


def provenance(
    *,
    config: Mapping[str, Any] | None = None,
    seed: int | None = None,
    inputs: Iterable[str | os.PathLike] = (),
    extra: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """Attributes that travel with every dataset and result (NetCDF-safe types).

    ``config`` is the set of config values the result depends on (its rule's
    params, :mod:`scintrack.pipeline.params`), never the whole config: its
    hash ``config_sha256`` is what ``archive``/``verify`` recompute from a
    config to check that the result belongs to it.  In a workflow job the git
    state is the one at the job's start and ``code_version`` is the code that
    ran (:mod:`scintrack.jobcode`, :data:`JOB`).
    """
    state = JOB.get("ran") or git_state(Path(__file__).resolve().parent)
    attrs: dict[str, Any] = {
        "scintrack_version": __version__,
        "git_commit": state["git_commit"],
        "git_dirty": int(state["git_dirty"]),
        "python_version": platform.python_version(),
        "input_sha256": canonical_json({str(p): sha256_file(p) for p in inputs}),
    }
    if "code_version" in state:  # in a workflow job: the code that ran, checked against the plan
        attrs["code_version"] = state["code_version"]
    if config is not None:
        attrs["config_sha256"] = hash_object(config)
    if seed is not None:
        attrs["seed"] = int(seed)
    for key, value in (extra or {}).items():
        attrs[key] = value if isinstance(value, (str, int, float)) else canonical_json(value)
    return attrs




def write_netcdf(ds: xr.Dataset, path: str | os.PathLike, *, compress: bool = True) -> str:
    """Write ``ds`` atomically with a ``content_sha256`` attribute; return the hash."""
    path = Path(path)
    ds = ds.copy()
    digest = content_hash(ds)
    ds.attrs["content_sha256"] = digest
    encoding = {}
    if compress:
        # level 1: measured on the run's largest results (a 139-MB trace-dynamics result, cycle-slip and Susi results)
        # against level 4, the files are about 1% larger and written 15-40% faster (1.43 s against 2.34, 0.41 against
        # 0.48, 0.28 against 0.36) and read faster; the values, hence content_sha256, are the same
        for name, var in ds.data_vars.items():
            if var.dtype.kind in "fiu" and var.ndim > 0:
                encoding[name] = {"zlib": True, "complevel": 1}
    def write(tmp: str) -> None:
        try:
            ds.to_netcdf(tmp, engine="netcdf4", encoding=encoding)
        except RuntimeError as exc:  # the NetCDF/HDF5 library reports a failed write (disk full, ...) without an errno
            if "NetCDF" not in str(exc) and "HDF" not in str(exc):
                raise
            raise OSError(f"the NetCDF library could not write it: {exc}") from None

    confirm_job_code()  # in a job: only output of the planned code
    atomic_write(path, write)
    return digest


def write_text(text: str | bytes, path: str | os.PathLike) -> None:
    """Write text or bytes atomically (temporary file, then rename), in a job only if its code is still the planned code."""
    confirm_job_code()
    atomic_bytes(path, text)


def read_attrs(path: str | os.PathLike) -> dict[str, Any]:
    """The global attributes of a NetCDF file, without reading its data."""
    import xarray as xr

    with xr.open_dataset(path, engine="netcdf4") as ds:
        return dict(ds.attrs)


class DatasetReadError(InputError):
    """A NetCDF file of the pipeline is missing, truncated or corrupt."""


def open_dataset(path: str | os.PathLike, *, lazy: bool = False) -> xr.Dataset:
    """Open a NetCDF result fully into memory (and close the file).

    ``lazy``: open it for reading instead, each variable read (and kept) when first used, and the file
    open until the Dataset is closed or collected: the same values, for jobs that use a few variables
    of large results (the figure and table rules).

    A missing, truncated or corrupt file raises :class:`DatasetReadError`
    (one line naming the file and the fix: outputs of the pipeline are
    regenerated by deleting them and rerunning).
    """
    import xarray as xr

    try:
        if lazy:
            return xr.open_dataset(path, engine="netcdf4")
        with xr.open_dataset(path, engine="netcdf4") as ds:
            return ds.load()
    except FileNotFoundError:
        raise DatasetReadError(f"{path}: no such file; rerun Snakemake to regenerate it") from None
    except (OSError, ValueError, RuntimeError, KeyError, IndexError) as exc:
        reason = one_line(getattr(exc, "strerror", None) or exc).split(": '", 1)[0][:160]
        raise DatasetReadError(f"{path}: not a readable NetCDF file ({reason}); it is truncated or corrupt: delete it and rerun Snakemake "
                               "to regenerate it (or restore it)") from None
