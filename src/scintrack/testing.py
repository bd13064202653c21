"""Conformance check of a tracker type against the Tracker protocol, for plug-in authors and the package's tests.

``check_tracker("my_type")`` in a plug-in's own test suite (``docs/adding-a-tracker.md``) builds the type
from a spec as the workflow does and runs it on two short inputs:

* **CSM**: Vila-Valls 2018's synthetic scintillation scenario (S4 = 0.5, tau0 = 0.4 s, the shared C/N0
  and dynamics of the project's ``tracking:`` settings, Ts = 10 ms), simulated by
  :func:`scintrack.experiments.scenario.simulate` exactly as the experiments do;
* **GPS**: a jammed GPS L1 C/A channel, 1-ms prompts of the receiver's correlator model
  (:func:`scintrack.experiments.gps_prompts.prompts_1ms`, fixed-gain front end): 45 dB-Hz, a jammer
  drops C/N0 to 25 dB-Hz halfway, data bits every 20 ms, a residual Doppler ramp.

On each it checks what the pipeline relies on (the contract of :class:`scintrack.trackers.base.Tracker`):

1. the spec passes the type's schema, the label is one non-empty line, ``SCHEMA``, ``TRACKING_KEYS``
   and ``PROVIDES`` have their types and ``TRACKING_KEYS`` names tracking settings;
2. ``from_spec`` reads no ``tracking`` key outside ``TRACKING_KEYS`` (the workflow hands an experiment
   only those) and builds from those keys alone;
3. ``run`` gives ``theta_d`` shaped like the prompts, real and finite, exactly the outputs
   ``request`` declared, each (trials, epochs) (``cov_fail_epoch``: (trials,)) and finite except where
   :data:`scintrack.experiments.guards.NONFINITE_ALLOWED` allows, and leaves its inputs unchanged;
4. batch invariance: each trial's outputs are the same alone, first or last in a batch, and with the
   batch reversed (bit for bit unless ``batch_atol`` is given);
5. when the type defines ``reference``: ``run`` agrees with it within ``rtol``/``atol`` on the CSM input
   (the loop is in lock there, so the two derivations differ by rounding only; on the jammed channel a
   rounding difference at a discriminator's +-pi edge may legitimately send the two on other cycles).

Each failure is an :class:`AssertionError` with one plain message naming the type, the input and what
is wrong.  Sizes are small (a few trials, a few hundred epochs): a check takes seconds, most of it
compiling a numba kernel the first time.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import fields, replace
from typing import Any

import numpy as np

#: epoch period of the CSM input and of the GPS input [s]
CSM_TS = 0.01
GPS_TS = 1e-3
#: GPS channel: C/N0 before and after the jammer's onset (halfway) [dB-Hz], residual Doppler [Hz] and its rate [Hz/s]
GPS_CN0_DBHZ = (45.0, 25.0)
GPS_DOPPLER_HZ = 5.0
GPS_RATE_HZ_S = 2.0
SEED = 20240601


class RecordingMapping(dict):
    """A mapping that remembers which keys were read (item, ``get``, ``in``; iterating reads every key)."""

    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        self.read: set[str] = set()

    def __getitem__(self, key):
        self.read.add(key)
        return super().__getitem__(key)

    def get(self, key, default=None):
        self.read.add(key)
        return super().get(key, default)

    def __contains__(self, key) -> bool:
        self.read.add(key)
        return super().__contains__(key)

    def _all(self):
        self.read.update(super().keys())

    def __iter__(self):
        self._all()
        return super().__iter__()

    def keys(self):
        self._all()
        return super().keys()

    def items(self):
        self._all()
        return super().items()

    def values(self):
        self._all()
        return super().values()

    def copy(self):
        self._all()
        return dict(super().items())


def default_tracking() -> dict[str, Any]:
    """The ``tracking:`` section of the project's ``config/config.yaml`` (the values the experiments use)."""
    from .config import load_config
    from .project import REPO

    return dict(load_config([REPO / "config" / "config.yaml"])["tracking"])


def toy_lut():
    """A small AR look-up table (two S4 points, one tau0, orders 1-3) that AR trackers can be built from."""
    import xarray as xr

    s4 = [0.5, 0.9]
    coef = np.zeros((2, 1, 2, 3, 3))
    for o in range(1, 4):
        coef[:, 0, 0, o - 1, :3] = [1.8, -0.9, 0.05]  # amplitude AR(3)
        coef[:, 0, 1, o - 1, :o] = [0.99, 0.0, 0.0][:o]  # phase AR(o)
    return xr.Dataset(
        {
            "coef": (("s4", "tau0", "component", "order", "lag"), coef),
            "const": (("s4", "tau0", "component", "order"), np.full((2, 1, 2, 3), 0.05)),
            "sigma2": (("s4", "tau0", "component", "order"), np.full((2, 1, 2, 3), 1e-3)),
        },
        coords={"s4": s4, "tau0": [0.2], "component": ["amplitude", "phase"], "order": [1, 2, 3], "lag": [1, 2, 3]},
    )


def csm_input(trials: int, epochs: int, tracking: Mapping[str, Any]):
    """(scenario, prompts (trials, epochs), TrackInit with a noise reference) of the CSM check scenario."""
    from .experiments.scenario import acquisition, effective_tracking, simulate

    scenario = {"duration_s": epochs * CSM_TS, "segments": [{"start_s": 0.0, "s4": 0.5, "tau0": 0.4}]}
    settings = effective_tracking(scenario, tracking)
    real = simulate("conformance_csm", scenario, settings, seed=SEED, ts=CSM_TS, nspa=8, warmup_s=1.0, trials=range(trials))
    init = replace(acquisition(real, settings), noise_reference=real.noise_reference())
    return scenario, np.ascontiguousarray(real.y), init


def gps_input(trials: int, epochs: int):
    """(scenario, prompts (trials, epochs), TrackInit with a noise reference) of the jammed GPS channel."""
    from .experiments.gps_prompts import BIT_MS, prompts_1ms
    from .signals.gps.correlator import NoiseStream
    from .trackers.base import TrackInit

    t = np.arange(epochs) * GPS_TS
    phi = 0.3 + 2 * np.pi * (GPS_DOPPLER_HZ * t + 0.5 * GPS_RATE_HZ_S * t**2)
    cn0 = np.where(np.arange(epochs) < epochs // 2, GPS_CN0_DBHZ[0], GPS_CN0_DBHZ[1])
    bits = np.repeat(np.random.default_rng(SEED).choice([-1.0, 1.0], size=-(-epochs // BIT_MS)), BIT_MS)[:epochs]
    rows = list(range(trials))
    y, _, sigma = prompts_1ms(NoiseStream(SEED, "conformance/gps", 1.0), rows, 0, phi, cn0, bits, GPS_CN0_DBHZ[0])
    ref = NoiseStream(SEED, "conformance/gps-reference", 1.0).epochs(rows, 0, 0, epochs)
    noise_reference = sigma * (ref[..., 1] + 1j * ref[..., 4])
    init = TrackInit(phase=np.angle(y[:, 0]), doppler_hz=np.full(trials, GPS_DOPPLER_HZ), rate_hz_s=np.zeros(trials),
                     noise_reference=noise_reference)
    scenario = {"duration_s": epochs * GPS_TS, "ts": GPS_TS, "cn0_dbhz": GPS_CN0_DBHZ[0], "fd0_hz": GPS_DOPPLER_HZ, "fr_hz_s": GPS_RATE_HZ_S,
                "clock": "ocxo", "segments": []}
    return scenario, np.ascontiguousarray(y), init


def _fail(type_name: str, where: str, what: str) -> AssertionError:
    return AssertionError(f"tracker type {type_name!r}{f' on the {where} input' if where else ''}: {what}")


def _rows(init, rows):
    """``init`` restricted to the trials ``rows`` (in that order)."""
    def take(v):
        if v is None:
            return None
        v = np.asarray(v)
        return v[rows] if v.ndim >= 1 and v.shape[0] == np.asarray(init.phase).shape[0] else v

    return replace(init, **{f.name: take(getattr(init, f.name)) for f in fields(init)})


def _arrays(out) -> dict[str, np.ndarray]:
    return {"theta_d": np.asarray(out.theta_d), **{k: np.asarray(v) for k, v in out.extras.items()}}


def _first_difference(a: np.ndarray, b: np.ndarray, atol: float, rtol: float = 0.0) -> str | None:
    """Where ``a`` and ``b`` differ by more than ``atol + rtol |b|`` (NaN equals NaN), as words; None if nowhere."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    same = (a == b) | (np.isnan(a) & np.isnan(b))  # equal infinities too
    with np.errstate(invalid="ignore"):
        bad = ~same & ~(np.abs(a - b) <= atol + rtol * np.abs(b))
    if not bad.any():
        return None
    idx = tuple(int(i) for i in np.argwhere(bad)[0])
    return f"{int(bad.sum())} value(s) differ, first at index {idx}: {a[idx]!r} against {b[idx]!r}"


def _check_output(type_name: str, where: str, out, y: np.ndarray, given: frozenset[str]) -> dict[str, np.ndarray]:
    from .experiments.guards import NONFINITE_ALLOWED
    from .trackers.base import TrackOutput

    if not isinstance(out, TrackOutput):
        raise _fail(type_name, where, f"run returned a {type(out).__name__}, not a scintrack.trackers.base.TrackOutput")
    theta = np.asarray(out.theta_d)
    if theta.shape != y.shape:
        raise _fail(type_name, where, f"run gave theta_d of shape {theta.shape} for prompts of shape {y.shape}; it must be (trials, epochs)")
    if not np.issubdtype(theta.dtype, np.floating):
        raise _fail(type_name, where, f"run gave theta_d of dtype {theta.dtype}; it must be a real float array (rad)")
    if set(out.extras) != set(given):
        raise _fail(type_name, where, f"run gave the optional outputs {sorted(out.extras)}, request() declared {sorted(given)}")
    arrays = _arrays(out)
    for key, v in arrays.items():
        shape = (y.shape[0],) if key == "cov_fail_epoch" else y.shape
        if v.shape != shape:
            raise _fail(type_name, where, f"run gave {key} of shape {v.shape}; it must be {shape}")
        if key in NONFINITE_ALLOWED or not np.issubdtype(v.dtype, np.number):
            continue
        bad = ~np.isfinite(v)
        if bad.any():
            idx = tuple(int(i) for i in np.argwhere(bad)[0])
            raise _fail(type_name, where, f"run gave {int(bad.sum())} non-finite value(s) of {key}, the first at (trial, epoch) {idx}")
    return arrays


def _check_batches(type_name: str, where: str, tracker, y: np.ndarray, init, full: dict[str, np.ndarray], atol: float) -> None:
    n = y.shape[0]
    batches = {"alone": [[0], [n - 1]], "reversed": [list(range(n - 1, -1, -1))]}
    for how, row_sets in batches.items():
        for rows in row_sets:
            part = _arrays(tracker.run(np.ascontiguousarray(y[rows]), _rows(init, rows)))
            for key, value in part.items():
                diff = _first_difference(value, full[key][rows], atol)
                if diff is not None:
                    raise _fail(type_name, where, f"trial {rows[0]}'s {key} depends on the batch it ran in ({how} against the whole batch of {n}): {diff}; "
                                                  "trials must not read each other")


def _check_reference(type_name: str, where: str, tracker, y: np.ndarray, init, full: dict[str, np.ndarray], rtol: float, atol: float) -> None:
    ref = tracker.reference(y, init)
    ref_arrays = _arrays(ref)
    if set(ref_arrays) != set(full):
        raise _fail(type_name, where, f"reference gave the outputs {sorted(ref_arrays)}, run gave {sorted(full)}")
    for key, value in full.items():
        diff = _first_difference(value, ref_arrays[key], atol, rtol)
        if diff is not None:
            raise _fail(type_name, where, f"run and reference disagree on {key} beyond rtol={rtol:g}, atol={atol:g}: {diff}")


def check_tracker(type_name: str, spec: Mapping[str, Any] | None = None, *, trials: int = 4, epochs: int = 300,
                  tracking: Mapping[str, Any] | None = None, rtol: float = 1e-9, atol: float = 1e-7, batch_atol: float = 0.0) -> dict[str, Any]:
    """Check the tracker type ``type_name`` (registered, built in or a plug-in) against the protocol (module docstring).

    ``spec``: its config entry without ``type`` (default: no keys); ``tracking``: the shared settings (default: the
    project's, :func:`default_tracking`); ``trials`` x ``epochs``: the size of each input (at least 2 trials);
    ``rtol``/``atol``: run against reference; ``batch_atol``: the batch-invariance tolerance (0: bit for bit).
    Returns what was checked (``{"label": ..., "tracking_keys_read": [...], "inputs": {name: shape}}``);
    raises AssertionError with a plain message on the first departure.
    """
    from .errors import ConfigError
    from .settings import TrackingSettings
    from .trackers import registry
    from .trackers.base import OUTPUT_NAMES, Tracker, TrackerContext

    if trials < 2:
        raise ValueError("check_tracker needs at least 2 trials (batch invariance)")
    try:
        kind = registry.get(type_name)
    except ValueError as exc:
        raise _fail(type_name, "", f"{exc}; is its package installed (entry point group scintrack.trackers)?") from None
    cls = kind.cls
    name = f"check_{type_name}"
    spec = {"type": type_name, **dict(spec or {})}
    try:
        registry.validate_specs({name: spec}, "the spec given to check_tracker")
    except ConfigError as exc:
        raise _fail(type_name, "", f"its spec is refused by its SCHEMA: {exc}") from None
    if not isinstance(cls.SCHEMA, Mapping) or not all(isinstance(v, Mapping) for v in cls.SCHEMA.values()):
        raise _fail(type_name, "", "SCHEMA must map each spec key to its JSON-Schema fragment (a mapping)")
    if not isinstance(cls.TRACKING_KEYS, tuple) or not all(isinstance(k, str) for k in cls.TRACKING_KEYS):
        raise _fail(type_name, "", f"TRACKING_KEYS must be a tuple of key names (got {cls.TRACKING_KEYS!r})")
    settings = {f.name for f in fields(TrackingSettings)}
    unknown = sorted(set(cls.TRACKING_KEYS) - settings)
    if unknown:
        raise _fail(type_name, "", f"TRACKING_KEYS names {', '.join(unknown)}, not a tracking setting (known: {', '.join(sorted(settings))})")
    if not isinstance(cls.PROVIDES, frozenset) or not cls.PROVIDES <= set(OUTPUT_NAMES):
        raise _fail(type_name, "", f"PROVIDES must be a frozenset of names of scintrack.trackers.base.OUTPUT_NAMES (got {cls.PROVIDES!r})")
    label = registry.label(name, {k: v for k, v in spec.items() if k != "label"})
    if not isinstance(label, str) or not label.strip() or "\n" in label:
        raise _fail(type_name, "", f"label() must return one non-empty line of text (got {label!r})")

    shared = dict(default_tracking() if tracking is None else tracking)
    declared = set(registry.tracking_keys(spec))
    has_reference = getattr(cls, "reference", None) is not Tracker.reference
    inputs = {}
    read_all: set[str] = set()
    for where, (scenario, y, init) in (("CSM", csm_input(trials, epochs, shared)), ("GPS", gps_input(trials, epochs))):
        ts = CSM_TS if where == "CSM" else GPS_TS
        recording = RecordingMapping(shared)
        tracker = registry.build(name, spec, TrackerContext(scenario=scenario, tracking=recording, lut=toy_lut(), ts=ts))
        read = set(recording.read)
        read_all |= read
        if read - declared:
            raise _fail(type_name, where, f"from_spec read the tracking key(s) {', '.join(sorted(read - declared))} that TRACKING_KEYS does not declare "
                                          f"(declared: {', '.join(sorted(declared)) or 'none'}); the workflow gives an experiment only the declared keys")
        only = {k: v for k, v in shared.items() if k in declared}
        try:
            registry.build(name, spec, TrackerContext(scenario=scenario, tracking=only, lut=toy_lut(), ts=ts))
        except KeyError as exc:
            raise _fail(type_name, where, f"from_spec needs the tracking key {exc} beyond TRACKING_KEYS") from None
        given = frozenset(tracker.request(cls.PROVIDES))
        if not given <= cls.PROVIDES:
            raise _fail(type_name, where, f"request() returned {sorted(given - cls.PROVIDES)}, outside PROVIDES")
        y_before, init_before = y.copy(), copy.deepcopy(init)
        full = _check_output(type_name, where, tracker.run(y, init), y, given)
        if not np.array_equal(y, y_before) or any(
                not np.array_equal(np.asarray(getattr(init, f.name)), np.asarray(getattr(init_before, f.name)))
                for f in fields(init) if getattr(init, f.name) is not None):
            raise _fail(type_name, where, "run modified its input prompts or TrackInit; it must treat them as read-only")
        _check_batches(type_name, where, tracker, y, init, full, batch_atol)
        if has_reference and where == "CSM":
            _check_reference(type_name, where, tracker, y, init, full, rtol, atol)
        inputs[where] = y.shape
    return {"label": label, "tracking_keys_read": sorted(read_all), "reference_checked": has_reference, "inputs": inputs}
