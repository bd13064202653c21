"""Real scintillation traces: the documented input format, its loader and validator.

The format (``docs/data.md``): one file per event holding a time axis and,
for each frequency band, the scintillation amplitude and phase after
open-loop processing (dynamics-free), sampled every ``Ts``:

* ``time``: seconds, strictly increasing, uniform step equal to the configured
  ``sampling.ts`` (within 1%);
* ``amplitude_<band>``: linear amplitude (not dB), normalised to unit mean
  power (mean of amplitude^2 between 0.5 and 2);
* ``phase_<band>``: radians, unwrapped (no jumps of 2 pi between samples);
* all arrays finite and of the same length.

Containers: NetCDF (variables with those names; a ``units`` attribute, if
present, must say ``s``, ``1`` and ``rad``), MATLAB ``.mat`` (scipy.io),
``.npz`` and ``.csv`` (a header row with those column names).  Every
violation raises :class:`TraceFormatError` with one line naming the file, the
variable and the fix.  :func:`load_trace` returns the canonical Dataset with
dims (band, time) that the rest of the pipeline reads.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import InputError, one_line

UNITS = {"time": ("s",), "amplitude": ("1", "", "linear"), "phase": ("rad", "radian", "radians")}


class TraceFormatError(InputError):
    """A trace file that does not follow docs/data.md."""


#: MAT-file v5 data types (miINT8 .. miUTF32; 8, 10 and 11 are reserved)
_MAT5_TYPES = frozenset({1, 2, 3, 4, 5, 6, 7, 9, 12, 13, 14, 15, 16, 17, 18})
_MAT5_MATRIX, _MAT5_COMPRESSED, _MAT5_MAX_DEPTH = 14, 15, 32


def _check_mat5(path: Path) -> None:
    """Refuse a MAT v5 file whose data elements have unknown types or overrun their parent.

    scipy 1.17's ``loadmat`` indexes a C table by the element type and
    segfaults on a corrupt type code (found by tests/test_fuzz.py), so the tag
    structure is walked here first (v4 and v7.3 files are left to ``loadmat``).
    """
    import zlib

    data = path.read_bytes()
    if len(data) < 128 or 0 in data[:4] or data[126:128] not in (b"IM", b"MI"):
        return
    order = "<" if data[126:128] == b"IM" else ">"
    if int.from_bytes(data[124:126], "little" if order == "<" else "big") != 0x0100:
        return

    def walk(buf: bytes, start: int, end: int, depth: int, top: bool) -> None:
        if depth > _MAT5_MAX_DEPTH:
            raise TraceFormatError(f"{path}: MAT-file elements nested deeper than {_MAT5_MAX_DEPTH}; the file is corrupt, re-export it")
        off = start
        while off < end:
            if off + 8 > end:
                raise TraceFormatError(f"{path}: MAT-file element tag truncated at byte {off}; the file is incomplete, re-export it")
            mdtype, nbytes = np.frombuffer(buf, dtype=f"{order}u4", count=2, offset=off).tolist()
            if mdtype >> 16:  # small data element: type and size in the first 4 bytes, data in the next 4
                mdtype, nbytes, size = mdtype & 0xFFFF, mdtype >> 16, 8
            else:
                size = 8 + nbytes + (0 if top else -nbytes % 8)
            if mdtype not in _MAT5_TYPES or (size == 8 and nbytes > 4) or off + min(size, 8 + nbytes) > end:
                raise TraceFormatError(f"{path}: MAT-file element at byte {off} is corrupt (type {mdtype}, {nbytes} bytes); re-export the file")
            if mdtype == _MAT5_MATRIX:
                walk(buf, off + 8, off + 8 + nbytes, depth + 1, False)
            elif mdtype == _MAT5_COMPRESSED:
                try:
                    inner = zlib.decompress(buf[off + 8 : off + 8 + nbytes])
                except zlib.error as exc:
                    raise TraceFormatError(f"{path}: MAT-file compressed element at byte {off} is corrupt ({exc}); re-export the file") from None
                walk(inner, 0, len(inner), depth + 1, True)
            off += size

    walk(data, 128, len(data), 0, True)


def _read_container(path: Path) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """Arrays by name and their declared units (when the container has any)."""
    suffix = path.suffix.lower()
    units: dict[str, str] = {}
    try:
        if suffix in (".nc", ".nc4", ".netcdf"):
            with xr.open_dataset(path) as ds:
                arrays = {k: np.asarray(ds[k].values) for k in list(ds.data_vars) + list(ds.coords)}
                units = {k: str(ds[k].attrs["units"]) for k in arrays if "units" in ds[k].attrs}
        elif suffix == ".mat":
            from scipy.io import loadmat

            _check_mat5(path)  # scipy's loadmat crashes the interpreter on some malformed files
            arrays = {k: np.asarray(v) for k, v in loadmat(path).items() if not k.startswith("__")}
        elif suffix == ".npz":
            with np.load(path) as z:
                arrays = {k: np.asarray(z[k]) for k in z.files}
        elif suffix == ".csv":
            import pandas as pd

            frame = pd.read_csv(path)
            arrays = {str(c).strip(): frame[c].to_numpy() for c in frame.columns}
        else:
            raise TraceFormatError(f"{path}: unknown trace container {suffix!r}; use .nc, .mat, .npz or .csv (docs/data.md)")
    except TraceFormatError:
        raise
    except Exception as exc:  # a corrupt container: say which file
        raise TraceFormatError(f"{path}: cannot be read as {suffix} ({type(exc).__name__}: {one_line(exc)}); check the file is complete") from None
    return arrays, units


def _vector(path: Path, arrays: dict[str, np.ndarray], name: str) -> np.ndarray:
    if name not in arrays:
        raise TraceFormatError(f"{path}: variable {name!r} is missing (have: {', '.join(sorted(arrays))}); see docs/data.md")
    v = np.asarray(arrays[name])
    if v.dtype.kind not in "fiu":
        raise TraceFormatError(f"{path}: {name!r} is not numeric (dtype {v.dtype})")
    v = v.astype(float).squeeze()
    if v.ndim != 1:
        raise TraceFormatError(f"{path}: {name!r} must be one-dimensional, got shape {np.shape(arrays[name])}")
    if not np.all(np.isfinite(v)):
        bad = int(np.flatnonzero(~np.isfinite(v))[0])
        raise TraceFormatError(f"{path}: {name!r} has a non-finite value (NaN or inf) at index {bad}; remove or interpolate the gap")
    return v


def _check_units(path: Path, units: dict[str, str], name: str, kind: str) -> None:
    u = units.get(name)
    if u is not None and u.strip().lower() not in UNITS[kind]:
        raise TraceFormatError(f"{path}: {name!r} has units {u!r}; expected {UNITS[kind][0]!r} (convert: docs/data.md)")


def load_trace(path: str | Path, bands: Sequence[str], ts: float, *, event: str, source: str) -> xr.Dataset:
    """Read and validate one event file; canonical Dataset with dims (band, time)."""
    path = Path(path)
    arrays, units = _read_container(path)
    time = _vector(path, arrays, "time")
    _check_units(path, units, "time", "time")
    if time.size < 2:
        raise TraceFormatError(f"{path}: 'time' has {time.size} samples; a trace needs many")
    step = np.diff(time)
    if np.any(step <= 0):
        bad = int(np.flatnonzero(step <= 0)[0])
        raise TraceFormatError(f"{path}: 'time' is not strictly increasing at index {bad + 1} ({float(time[bad]):.6g} s -> {float(time[bad + 1]):.6g} s); sort it and drop duplicates")
    if np.max(np.abs(step - ts)) > 0.01 * ts:
        raise TraceFormatError(
            f"{path}: 'time' step is {np.median(step):g} (range {step.min():g}..{step.max():g}), expected sampling.ts = {ts:g} s; "
            "time must be in seconds and uniformly sampled (resample the trace)"
        )
    rho, theta = [], []
    for band in bands:
        a_name, p_name = f"amplitude_{band}", f"phase_{band}"
        a, p = _vector(path, arrays, a_name), _vector(path, arrays, p_name)
        _check_units(path, units, a_name, "amplitude")
        _check_units(path, units, p_name, "phase")
        for name, v in ((a_name, a), (p_name, p)):
            if v.size != time.size:
                raise TraceFormatError(f"{path}: {name!r} has {v.size} samples but 'time' has {time.size}; all arrays must have the same length")
        if np.any(a < 0):
            raise TraceFormatError(f"{path}: {a_name!r} has negative values: is it in dB? Give the linear amplitude (10**(dB/20))")
        with np.errstate(over="ignore"):  # a huge amplitude gives power inf, refused below
            power = float(np.mean(a**2))
        if not 0.5 <= power <= 2.0:
            raise TraceFormatError(f"{path}: {a_name!r} has mean power {power:.3g}; normalise the amplitude to unit mean power (divide by its rms)")
        jumps = np.abs(np.diff(p))
        if np.any(jumps > 1.5 * np.pi):
            at = int(np.flatnonzero(jumps > 1.5 * np.pi)[0])
            raise TraceFormatError(f"{path}: {p_name!r} jumps by {jumps[at]:.3g} rad at index {at + 1}: is it wrapped or in degrees? Give the unwrapped phase in rad")
        rho.append(a)
        theta.append(p)
    ds = xr.Dataset(
        {
            "amplitude": (("band", "time"), np.array(rho), {"units": "1", "long_name": "scintillation amplitude rho_s (unit mean power)"}),
            "phase": (("band", "time"), np.array(theta), {"units": "rad", "long_name": "scintillation phase theta_s (unwrapped)"}),
        },
        coords={"band": list(bands), "time": ("time", time - time[0], {"units": "s"})},
    )
    ds.attrs.update({"event": event, "source": source, "original_file": path.name})
    return ds
