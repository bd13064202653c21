"""The scintillation traces of Susi et al. 2014's two 1-ms scenarios.

* **High latitude** (the chapter's Sec. 4.1: SPLN model through a Spirent
  simulator, "S4 at noise level", "very high Phi60"): always a SYNTHETIC
  SURROGATE, a phase-screen realisation (:mod:`scintrack.signals.phase_screen`)
  whose fast drift and steep spectrum give strong phase and weak amplitude
  scintillation.  The SPLN output is not public.
* **Equatorial** (Sec. 4.2: real JRC Hanoi data, "moderate amplitude and high
  phase"): the real trace of ``real_event`` when the JRC traces are configured
  (``real_traces.sources``; the canonical trace of Sec. VI-E, resampled to the
  scenario's Ts), otherwise a labelled phase-screen SURROGATE with moderate S4.

* **High latitude, real-index event** (a trace with ``real_indices``): a
  SURROGATE phase driven by the real Septentrio indices of the pre-declared
  event (:func:`scintrack.data.biscef.strongest_run` over the run of
  ``duration_s / 60`` minutes, :mod:`scintrack.data.index_trace`), built by
  rule ``susi_index_trace`` from the real index rows; its version follows its
  parameters, the index files' sha256 and the generator code.

The surrogates are made by the same generator as the Sec. VI-E surrogate
(:func:`scintrack.data.surrogate.surrogate_event`, L1 only) with the
parameters of ``susi_2014.traces.<name>.surrogate`` (plus the shared screen
geometry of ``real_traces.surrogate``); their version follows those
parameters and the generator code.

Everything but :func:`at_rate` shapes the config (the workflow calls it to
build the DAG), so numpy is imported inside :func:`at_rate` only.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from .surrogate_spec import surrogate_params, surrogate_version
from .versioning import code_version, dataset_version

if TYPE_CHECKING:
    import numpy as np
    import xarray as xr

FOLDER = "data/synthetic/susi_surrogate_{name}"
INDEX_FOLDER = "data/synthetic/susi_index_{name}"
INDEX_GENERATOR = "scintrack.data.index_trace"
#: bumped whenever a code change alters the generated values (the code version follows the code anyway)
INDEX_LABEL = "1"


def trace_spec(config: Mapping[str, Any], name: str) -> Mapping[str, Any]:
    traces = config["susi_2014"]["traces"]
    if name not in traces:
        raise KeyError(f"susi_2014.traces has no trace {name!r} (known: {', '.join(traces)})")
    return traces[name]


def uses_real_indices(config: Mapping[str, Any], name: str) -> bool:
    """True when the trace is driven by the real BiScEF indices of an event (``real_indices``)."""
    return "real_indices" in trace_spec(config, name)


def index_trace_params(config: Mapping[str, Any], name: str) -> dict[str, Any]:
    """What a real-index trace depends on: its settings, the seed, the index files' sha256 and the generator's code version."""
    from ..project import project_file
    from .biscef import ELEVATION_MIN_DEG, file_params

    spec = trace_spec(config, name)
    ri = spec["real_indices"]
    window = float(spec.get("window_s", 60.0))
    return {
        "seed": int(config["seed"]), "name": name, "ts": float(spec["ts"]), "duration_s": float(spec["duration_s"]), "window_s": window,
        "minutes": int(round(float(spec["duration_s"]) / window)), "cn0_min_dbhz": float(ri["cn0_min_dbhz"]),
        "strength": str(ri["strength"]), "f_floor_hz": float(ri["f_floor_hz"]),
        "detrend_hz": float(config["susi_2014"]["indices"]["detrend_hz"]),
        "elevation_min_deg": ELEVATION_MIN_DEG,
        "biscef": {entry: f["sha256"] for entry, f in file_params(project_file(config["real_traces"]["registry"])).items()},
        "generator_version": code_version(INDEX_LABEL, INDEX_GENERATOR),
    }


def uses_real(config: Mapping[str, Any], name: str) -> bool:
    """True when the trace comes from a configured real JRC event."""
    event = trace_spec(config, name).get("real_event")
    return bool(event) and event in config["real_traces"]["sources"]


def susi_surrogate_params(config: Mapping[str, Any], name: str) -> dict[str, Any]:
    """Generator parameters of one Susi surrogate (the Sec. VI-E generator's parameter set)."""
    spec = trace_spec(config, name)
    sur = dict(spec["surrogate"])
    base = dict(config)
    rt = dict(config["real_traces"])
    rt["bands"] = ["L1"]
    rt["fit_s"], rt["eval_s"] = 0.0, float(spec["duration_s"])
    rt["surrogate"] = {**rt["surrogate"], "events": {f"susi_{name}": sur}, "window_s": float(spec.get("window_s", rt["surrogate"]["window_s"]))}
    base["real_traces"] = rt
    base["sampling"] = {**config["sampling"], "ts": float(spec["ts"])}
    return surrogate_params(base, f"susi_{name}")


def trace_input(config: Mapping[str, Any], name: str) -> dict[str, Any]:
    """What the trace of one Susi scenario depends on (the rule params)."""
    spec = trace_spec(config, name)
    if uses_real_indices(config, name):
        return {"real_indices": index_trace_params(config, name)}
    if uses_real(config, name):
        event = spec["real_event"]
        return {"real_event": event, "source": dict(config["real_traces"]["sources"][event]), "ts": float(spec["ts"]),
                "trace_ts": float(config["sampling"]["ts"]), "duration_s": float(spec["duration_s"])}
    return {"surrogate": susi_surrogate_params(config, name)}


def trace_file(config: Mapping[str, Any], name: str) -> str:
    spec = trace_spec(config, name)
    if uses_real_indices(config, name):
        return f"{INDEX_FOLDER.format(name=name)}/{dataset_version(INDEX_GENERATOR, INDEX_LABEL, index_trace_params(config, name))}.nc"
    if uses_real(config, name):
        return f"data/traces/real/{spec['real_event']}.nc"
    return f"{FOLDER.format(name=name)}/{surrogate_version(susi_surrogate_params(config, name))}.nc"


def at_rate(ds: xr.Dataset, ts: float, band: str = "L1") -> tuple[np.ndarray, np.ndarray, str]:
    """(amplitude, phase, source) of one band at the period ``ts``.

    A trace already at ``ts`` is returned as stored; a real trace at another
    rate is linearly interpolated (amplitude and unwrapped phase), which adds
    nothing above the trace's own Nyquist frequency.
    """
    import numpy as np

    t = np.asarray(ds["time"].values, dtype=float)
    rho = ds["amplitude"].sel(band=band).values.astype(float)
    theta = ds["phase"].sel(band=band).values.astype(float)
    step = float(np.median(np.diff(t))) if t.size > 1 else ts
    if abs(step - ts) <= 1e-9 * ts:
        return rho, theta, str(ds.attrs.get("source", "unknown"))
    grid = np.arange(int(np.floor((t[-1] - t[0]) / ts)) + 1) * ts + t[0]
    return np.interp(grid, t, rho), np.interp(grid, t, theta), str(ds.attrs.get("source", "unknown"))
