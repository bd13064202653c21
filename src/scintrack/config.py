"""Load, merge and validate the pipeline configuration.

The same JSON Schema (``workflow/schemas/config.schema.yaml``) serves
Snakemake (``snakemake.utils.validate``) and this module, which turns the
first violation into one line that names the key and the fix.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from .errors import ConfigError
from .yamlio import DuplicateKeyError, deep_merge, yaml_load


def load_config(paths: Iterable[str | Path]) -> dict[str, Any]:
    """Read and merge YAML files in order (later ones override earlier ones).

    A key given twice in one mapping of a file (at any depth) is refused with
    the file, the line of the repeat and the key (:class:`~.yamlio.DuplicateKeyError`):
    YAML readers keep only the last, which would drop the first silently.
    """
    merged: dict[str, Any] = {}
    for path in paths:
        path = Path(path)
        try:
            data = yaml_load(path.read_text(encoding="utf-8")) or {}
        except FileNotFoundError:
            raise ConfigError(f"config file {path} not found; pass an existing --configfile") from None
        except UnicodeDecodeError as exc:
            raise ConfigError(f"config file {path} is not UTF-8 text (byte {exc.start}); save it as UTF-8 YAML") from None
        except RecursionError:
            raise ConfigError(f"config file {path} nests too deeply to be a config; fix its syntax there") from None
        except OSError as exc:
            raise ConfigError(f"config file {path} cannot be read ({exc.strerror or exc}); pass a readable --configfile") from None
        except DuplicateKeyError as exc:
            raise ConfigError(f"config file {path}:{exc.line}: key {exc.key!r} is given twice in one mapping (first on line {exc.first_line}); "
                              "keep one of them (a YAML reader keeps only the last and drops the other)") from None
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
            where = f"{path}:{mark.line + 1}:{mark.column + 1}" if mark is not None else str(path)
            problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
            raise ConfigError(f"config file {where} is not valid YAML ({problem}); fix its syntax there") from None
        if not isinstance(data, Mapping):
            raise ConfigError(f"config file {path} must hold a mapping at the top level")
        merged = deep_merge(merged, data)
    return merged


def typed_overrides(overrides: Mapping[str, Any]) -> dict[str, Any]:
    """``--config`` values with the types they would have in a YAML config file.

    Snakemake parses ``--config key=VALUE`` with int/float/bool and then YAML's
    *base* loader, which leaves every value inside a nested mapping a string
    (``tracking={"pll_bandwidth_hz": 15.0}`` gives ``'15.0'``).  Each string
    leaf is read again with ``yaml.safe_load`` (a value that does not parse
    stays the string it was).
    """

    def convert(value: Any) -> Any:
        if isinstance(value, Mapping):
            return {k: convert(v) for k, v in value.items()}
        if isinstance(value, list):
            return [convert(v) for v in value]
        if isinstance(value, str):
            try:
                parsed = yaml_load(value)
            except yaml.YAMLError:
                return value
            return convert(parsed) if isinstance(parsed, (Mapping, list)) else parsed
        return value

    return {key: convert(value) for key, value in dict(overrides).items()}


def _key_path(error) -> str:
    parts = []
    for item in error.absolute_path:
        parts.append(f"[{item}]" if isinstance(item, int) else (f".{item}" if parts else str(item)))
    return "".join(parts) or "<top level>"


def format_validation_error(error, source: str = "config/config.yaml") -> str:
    """One line naming the offending key, the rule it breaks and the fix.

    An unknown key (``additionalProperties``) is named itself, with the keys
    allowed there, so the line points at the typo rather than at its parent.
    """
    key = _key_path(error)
    schema = error.schema if isinstance(error.schema, Mapping) else {}
    if error.validator == "additionalProperties" and isinstance(error.instance, Mapping):
        allowed = list(schema.get("properties", {}))
        unknown = [k for k in error.instance if k not in allowed]
        if unknown and not schema.get("patternProperties"):
            name = str(unknown[0])
            key = name if key == "<top level>" else f"{key}.{name}"
            shown = ", ".join(allowed[:12]) + (", ..." if len(allowed) > 12 else "")
            return f"invalid config value at '{key}': unknown key {name!r} (allowed here: {shown}); remove or rename it in {source}"
    description = schema.get("description")
    hint = f" ({description})" if description else ""
    message = " ".join(error.message.split())
    return f"invalid config value at '{key}': {message}{hint}; fix it in {source} or your --configfile/--config overlay"


# Placeholder for "the file to fix" while validating; :func:`locate` replaces it
# by the config layer that actually sets the offending key.
SOURCE = "\x00config source\x00"


def _has_path(data: Any, path: str) -> int:
    """How many characters of the key path ``path`` (``a.b[0].c``) ``data`` holds (keys may contain dots)."""
    done = 0
    while path:
        if path.startswith("["):
            end = path.find("]")
            try:
                index = int(path[1:end])
            except ValueError:
                return done
            if not isinstance(data, list) or not -len(data) <= index < len(data):
                return done
            data, step = data[index], end + 1
        else:
            if not isinstance(data, Mapping):
                return done
            keys = [k for k in map(str, data) if path == k or path.startswith(k + ".") or path.startswith(k + "[")]
            if not keys:
                return done
            key = max(keys, key=len)
            data = next(v for k, v in data.items() if str(k) == key)
            step = len(key)
        done += step
        path = path[step:]
        if path.startswith("."):
            path, done = path[1:], done + 1
    return done


def source_of(key: str, layers: Sequence[tuple[str, Mapping[str, Any]]]) -> str:
    """The layer (``(name, mapping)`` in merge order, last wins) that sets ``key``, else the one holding most of its path."""
    if not layers:
        return "config/config.yaml"
    depth = [(_has_path(data, key), i) for i, (_, data) in enumerate(layers)]
    full = [i for d, i in depth if d == len(key)]
    if full and key:
        return layers[full[-1]][0]
    best = max(depth, key=lambda t: (t[0], t[1]))
    return layers[best[1]][0] if best[0] > 0 else layers[0][0]


def locate(message: str, layers: Sequence[tuple[str, Mapping[str, Any]]]) -> str:
    """``message`` with :data:`SOURCE` replaced by the layer that sets the key it names (``at 'key'``)."""
    match = re.search(r"at '([^']*)'", message)
    key = match.group(1) if match else ""
    where = source_of("" if key == "<top level>" else key, layers)
    message = message.replace(f"{SOURCE} or your --configfile/--config overlay", where).replace(SOURCE, where)
    return message


def validate_config(config: Mapping[str, Any], schema_path: str | Path, source: str = "config/config.yaml") -> None:
    """Validate against the JSON Schema, then check cross-key consistency."""
    import jsonschema

    schema = yaml_load(Path(schema_path).read_text())
    validator = jsonschema.Draft202012Validator(schema)
    error = jsonschema.exceptions.best_match(validator.iter_errors(config))
    if error is not None:
        raise ConfigError(format_validation_error(error, source))
    check_consistency(config, source)


def check_consistency(config: Mapping[str, Any], source: str = "config/config.yaml") -> None:
    """Rules the schema cannot express (references between keys).

    A pure function of the config and the code: a config that passed is
    remembered under the code version of this module's import closure
    (:func:`scintrack.codeversion.remembered`) and not checked again, so
    Snakemake builds the DAG without importing the tracker modules (numba)
    and xarray until the config or the code changes.  A config
    that fails is checked, and refused, every time.
    """
    from .codeversion import remembered

    def check() -> bool:
        _check_consistency(config, source)
        return True

    def keep() -> bool:  # a tracker type registered outside the package (a test, a plug-in) is not in the code version
        from .trackers.registry import from_package

        return all(from_package(spec["type"]) for spec in config["trackers"].values())

    remembered(__name__, "check_consistency", config, check, keep)


def _check_zhao_readings(config: Mapping[str, Any]) -> None:
    """Every pre-declared Zhao reading names receiver settings that exist and a ``jammed_from`` that does."""
    from .experiments.zhao_readings import reading_spec

    for reading in (config.get("zhao_readings") or {}).get("readings", {}):
        reading_spec(config, reading)


def _check_consistency(config: Mapping[str, Any], source: str) -> None:
    from .trackers.registry import validate_specs

    _check_finite(config, "", source)
    validate_specs(config["trackers"], source)
    grid_s4 = set(config["ar_training"]["s4"])
    grid_tau0 = set(config["ar_training"]["tau0"])
    vv = config["figures"]["vila_valls_2018"]
    for name, case in vv["ar_cases"].items():
        if case["s4"] not in grid_s4 or case["tau0"] not in grid_tau0:
            raise ConfigError(
                f"invalid config value at 'figures.vila_valls_2018.ar_cases.{name}': "
                f"(S4={case['s4']}, tau0={case['tau0']}) is not on the ar_training grid; "
                f"add it to ar_training.s4/tau0 in {source}"
            )
    max_order = config["ar_models"]["max_order"]
    if max(vv["psd_orders"]) > max_order:
        raise ConfigError(
            f"invalid config value at 'figures.vila_valls_2018.psd_orders': order {max(vv['psd_orders'])} "
            f"exceeds ar_models.max_order={max_order}; raise max_order or drop the order in {source}"
        )
    if vv["pacf_lags_shown"] > config["ar_models"]["pacf_lags"]:
        raise ConfigError(
            "invalid config value at 'figures.vila_valls_2018.pacf_lags_shown': larger than "
            f"ar_models.pacf_lags={config['ar_models']['pacf_lags']}; fix it in {source}"
        )
    _check_experiments(config, source)
    _check_zhao_readings(config)
    _check_real_traces(config, source)
    _check_trace_scenarios(config, source)
    for name in config["floors"]["scenarios"]:
        sc = config["scenarios"].get(name)
        if sc is None or len(sc["segments"]) != 1:
            raise ConfigError(f"invalid config value at 'floors.scenarios': {name!r} must be a scenario with one (S4, tau0) segment; fix it in {source}")
    n_epochs = config["ar_training"]["duration_s"] / config["sampling"]["ts"]
    if n_epochs < 20 * max(max_order, config["ar_models"]["pacf_lags"]):
        raise ConfigError(
            f"invalid config value at 'ar_training.duration_s': {n_epochs:.0f} epochs are too few to fit "
            f"AR({max_order}) and a {config['ar_models']['pacf_lags']}-lag PACF; lengthen it in {source}"
        )
    from .validity import check_model_ranges  # S4 the generators realise; AR look-ups on the grid (scintrack.validity)
    check_model_ranges(config, source)


def _check_finite(value: Any, key: str, source: str) -> None:
    """No NaN or infinity anywhere (JSON Schema bounds do not catch them: NaN compares false with every bound)."""
    if isinstance(value, Mapping):
        for k, v in value.items():
            _check_finite(v, f"{key}.{k}" if key else str(k), source)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _check_finite(v, f"{key}[{i}]", source)
    elif isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(f"invalid config value at '{key}': {value} is not a finite number; give a finite value in {source}")


def _check_trace_scenarios(config: Mapping[str, Any], source: str) -> None:
    """A trace scenario (Susi 2014) names an existing susi_2014.traces entry at its own Ts, long enough for fit_s + duration_s."""
    traces = config["susi_2014"]["traces"]
    for name, sc in config["scenarios"].items():
        if sc.get("scintillation_model") == "trace" and "trace" not in sc:
            raise ConfigError(f"invalid config value at 'scenarios.{name}': scintillation_model trace needs trace: {{name, fit_s}}; add it in {source}")
        if "trace" not in sc:
            continue
        tr = sc["trace"]
        if tr["name"] not in traces:
            raise ConfigError(f"invalid config value at 'scenarios.{name}.trace.name': {tr['name']!r} is not under susi_2014.traces "
                              f"(known: {', '.join(traces)}); fix it in {source}")
        spec = traces[tr["name"]]
        ts = float(sc.get("ts", config["sampling"]["ts"]))
        if abs(float(spec["ts"]) - ts) > 1e-12:
            raise ConfigError(f"invalid config value at 'scenarios.{name}.ts': {ts:g} s differs from susi_2014.traces.{tr['name']}.ts = "
                              f"{float(spec['ts']):g} s; make them equal in {source}")
        need = float(tr["fit_s"]) + float(sc["duration_s"])
        if float(spec["duration_s"]) + 1e-9 < need:
            raise ConfigError(f"invalid config value at 'susi_2014.traces.{tr['name']}.duration_s': {float(spec['duration_s']):g} s is shorter than "
                              f"scenarios.{name}.trace.fit_s + duration_s = {need:g} s; lengthen it in {source}")


def _check_experiments(config: Mapping[str, Any], source: str) -> None:
    scenarios, trackers = config["scenarios"], config["trackers"]
    for name, sc in scenarios.items():
        starts = [seg["start_s"] for seg in sc["segments"]]
        if starts and (starts[0] != 0 or any(b <= a for a, b in zip(starts, starts[1:]))):
            raise ConfigError(f"invalid config value at 'scenarios.{name}.segments': start_s must begin at 0 and increase; fix it in {source}")
        if sc["duration_s"] <= config["tracking"]["steady_state_start_s"]:
            raise ConfigError(
                f"invalid config value at 'scenarios.{name}.duration_s': {sc['duration_s']} s ends before "
                f"tracking.steady_state_start_s={config['tracking']['steady_state_start_s']}; lengthen it in {source}"
            )
    for name, exp in config["experiments"].items():
        for sc in exp["scenarios"]:
            if sc not in scenarios:
                raise ConfigError(f"invalid config value at 'experiments.{name}.scenarios': {sc!r} is not defined under 'scenarios'; add it in {source}")
        for tr in exp["trackers"]:
            if tr not in trackers:
                raise ConfigError(f"invalid config value at 'experiments.{name}.trackers': {tr!r} is not defined under 'trackers'; add it in {source}")
            if trackers[tr].get("design") == "trace":  # its AR models are fitted on the scenario's trace
                csm = [sc for sc in exp["scenarios"] if "trace" not in scenarios.get(sc, {})]
                if csm:
                    raise ConfigError(
                        f"invalid config value at 'experiments.{name}.trackers': {tr!r} has design: trace (AR models fitted on a recorded "
                        f"trace) but scenario {csm[0]!r} has no trace (scintillation_model: trace); use a design: scenario tracker there "
                        f"or a trace scenario, in {source}")
        if exp["shards"] > exp["trials"]:
            raise ConfigError(f"invalid config value at 'experiments.{name}.shards': more shards ({exp['shards']}) than trials ({exp['trials']}); fix it in {source}")


def _check_real_traces(config: Mapping[str, Any], source: str) -> None:
    rt = config["real_traces"]
    where = "invalid config value at 'real_traces"
    events, bands = rt["events"], rt["bands"]
    if rt["sources"]:
        missing = [e for e in events if e not in rt["sources"]]
        extra = [e for e in rt["sources"] if e not in events]
        if missing or extra:
            raise ConfigError(
                f"{where}.sources': real data must be given for every event or none (missing: {missing or '-'}, unknown: {extra or '-'}); fix it in {source}"
            )
    else:
        missing = [e for e in events if e not in rt["surrogate"]["events"]]
        if missing:
            raise ConfigError(f"{where}.surrogate.events': no surrogate settings for {missing}; add them in {source}")
        for name, ev in rt["surrogate"]["events"].items():
            times = [pt[0] for pt in ev["profile"]]
            if times[0] != 0 or any(b <= a for a, b in zip(times, times[1:])):
                raise ConfigError(f"{where}.surrogate.events.{name}.profile': times must start at 0 and increase; fix it in {source}")
    for tr in rt["trackers"]:
        if tr not in config["trackers"]:
            raise ConfigError(f"{where}.trackers': {tr!r} is not defined under 'trackers'; add it in {source}")
    st = rt["static_tracker"]
    if st not in config["trackers"] or config["trackers"][st]["type"] != "aekf_ar" or not config["trackers"][st].get("static"):
        raise ConfigError(f"{where}.static_tracker': {st!r} must name an aekf_ar tracker with static: true under 'trackers'; fix it in {source}")
    for fig, ev, band in [("fig10", rt["fig10"]["event"], None), ("fig11", rt["fig11"]["event"], rt["fig11"]["band"])] + [
        ("fig15", e, b) for e, b in rt["fig15"]
    ]:
        if ev not in events or (band is not None and band not in bands):
            raise ConfigError(f"{where}.{fig}': ({ev}, {band}) is not among real_traces.events/bands; fix it in {source}")
    if rt["fig10"]["start_s"] + rt["fig10"]["length_s"] > rt["fit_s"] + rt["eval_s"]:
        raise ConfigError(f"{where}.fig10': the window ends after the trace (fit_s + eval_s); fix it in {source}")
    if rt["rmse_start_s"] >= rt["eval_s"]:
        raise ConfigError(f"{where}.rmse_start_s': not before eval_s; fix it in {source}")
    if max(rt["s4_window_s"], rt["pacf_segment_s"]) > rt["fit_s"] + rt["eval_s"]:
        raise ConfigError(f"{where}.s4_window_s/pacf_segment_s': longer than the trace; fix it in {source}")
