"""Tracker types by name: registration, construction, labels and config validation.

A tracker type is one module.  Its class registers itself with the
:func:`register` decorator and provides

* ``from_spec(spec, context) -> Tracker`` (classmethod): build from the config
  entry ``spec`` (``config["trackers"][name]``) and a :class:`~.base.TrackerContext`;
* ``label(name, spec) -> str`` (static): the plain-text name used in figures
  and tables (a ``label:`` key in the spec overrides it, see :func:`label`);
* ``SCHEMA``: a JSON-Schema ``properties`` dict of its spec keys (``type`` and
  ``label`` are added here);
* ``PROVIDES``: the optional outputs its ``run`` can give, and ``request``,
  ``design_point``, ``needs_noise_reference`` (the :class:`~.base.Tracker`
  protocol, which a tracker class subclasses, has their defaults);
* ``TRACKING_KEYS``: the keys of the shared ``config["tracking"]`` section its
  ``from_spec`` reads.  The workflow hands an experiment only the tracking
  values its trackers read (:mod:`scintrack.pipeline.params`), so a change of
  ``tracking.pll_bandwidth_hz`` reruns the experiments with a PLL and no
  other; a test builds every configured tracker from exactly these keys.

Every module of the ``scintrack.trackers`` package is imported on first use
(:func:`_load`), so a new tracker module registers itself by existing: no list
to edit.  (Code versions know this: :mod:`scintrack.codeversion` counts the
whole package for any rule that imports this registry.)  A module imported by
anybody else (a test) registers its types the same way.  The config schema
(``workflow/schemas/config.schema.yaml``) only requires ``type``; the
per-type keys are checked by :func:`validate_specs` against the fragments.

Plug-ins: an installed distribution declares a tracker type as an entry point
of the group ``scintrack.trackers`` (``<type name> = <module>:<class>``,
:data:`scintrack.codeversion.PLUGIN_GROUP`); :func:`load_plugins`, part of
the first use, registers each under its entry-point name with the same
checks as :func:`register`, so ``type: <name>`` then works like a built-in
type.  A name that clashes (with a built-in type or another distribution's
entry point), a module that fails to import or a target that is not a
tracker class is a :class:`PluginError`: one line naming the distribution
and the entry point.  Their code enters code versions through
:func:`scintrack.codeversion.plugin_code`.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

from ..errors import ConfigError
from .base import Tracker, TrackerContext

__all__ = [
    "PluginError", "TrackerContext", "TrackerType", "build", "from_package", "get", "known_types", "label", "load_plugins", "register", "spec_schema",
    "tracking_keys", "validate_specs",
]


class PluginError(ConfigError):
    """An installed plug-in tracker type cannot be used (a name clash, an import failure, not a tracker class); one line."""


@dataclass(frozen=True)
class TrackerType:
    name: str
    cls: type
    from_spec: Callable[[Mapping[str, Any], TrackerContext], Tracker]
    label: Callable[[str, Mapping[str, Any]], str]
    schema: Mapping[str, Any]
    tracking_keys: tuple[str, ...]
    #: the entry point of a plug-in type (:class:`scintrack.codeversion.PluginEntry`); None for the others
    plugin: Any = None


_TYPES: dict[str, TrackerType] = {}
_loaded = False


def register(name: str) -> Callable[[type], type]:
    """Class decorator: make ``cls`` the tracker type ``name`` (``type: name`` in the config)."""

    def deco(cls: type) -> type:
        for attr in ("from_spec", "label", "run", "SCHEMA", "TRACKING_KEYS", "PROVIDES"):
            if not _defines(cls, attr):
                raise TypeError(f"tracker type {name!r}: {cls.__name__} has no {attr}")
        old = _TYPES.get(name)
        if old is not None and old.cls.__qualname__ != cls.__qualname__:
            raise ValueError(f"tracker type {name!r} is already registered by {old.cls.__module__}.{old.cls.__qualname__}")
        _TYPES[name] = TrackerType(
            name=name, cls=cls, from_spec=cls.from_spec, label=cls.label, schema=dict(cls.SCHEMA), tracking_keys=tuple(cls.TRACKING_KEYS)
        )
        return cls

    return deco


def _defines(cls: type, attr: str) -> bool:
    """``cls`` or a base below the :class:`~.base.Tracker` protocol defines ``attr`` (the protocol's stubs do not count)."""
    for klass in cls.__mro__:
        if klass is Tracker:
            return False
        if attr in vars(klass):
            return True
    return False


def _load() -> None:
    """Import every module of this package, then register the installed plug-ins (:func:`load_plugins`).

    A plug-in that fails raises :class:`PluginError` on this and every later use.
    """
    global _loaded
    if not _loaded:
        import pkgutil

        package = __name__.rpartition(".")[0]
        for info in pkgutil.iter_modules(importlib.import_module(package).__path__):
            importlib.import_module(f"{package}.{info.name}")
        load_plugins()
        _loaded = True


def load_plugins(path=None) -> list[str]:
    """Register the tracker type of every entry point of ``scintrack.trackers`` on ``path`` (default ``sys.path``).

    Returns the type names registered.  Checks, in this order, each failure one
    :class:`PluginError` line naming the distribution and the entry point: the
    name is declared by one distribution only and is not a type of this package
    (nor one registered by other code); the target imports; it is a class that
    :func:`register` accepts.  A target whose module registers itself under the
    same name with ``@register`` is the same type (no clash).
    """
    from ..codeversion import PLUGIN_GROUP, plugin_entry_points

    entries = plugin_entry_points(path)
    by_name: dict[str, list] = {}
    for entry in entries:
        by_name.setdefault(entry.name, []).append(entry)
    for name, group in by_name.items():
        if len(group) > 1:
            raise PluginError(f"plug-in tracker type {name!r} is declared twice in the entry-point group {PLUGIN_GROUP}: "
                              f"{' and '.join(e.describe() for e in group)}; rename the entry point in one package's pyproject.toml and reinstall it, "
                              "or uninstall one of them")
    done = []
    for entry in entries:
        old = _TYPES.get(entry.name)
        if old is not None and _in_package(old.cls):
            raise PluginError(f"plug-in tracker type {entry.name!r} of the {entry.describe()} clashes with the built-in type of "
                              f"{old.cls.__module__}; rename the entry point in {entry.distribution}'s pyproject.toml and reinstall it, "
                              f"or uninstall {entry.distribution}")
        try:
            target = _load_entry(entry)
        except Exception as exc:  # noqa: BLE001 (any failure of foreign code is reported as the plug-in's)
            detail = " ".join(f"{type(exc).__name__}: {exc}".split())
            raise PluginError(f"plug-in tracker type {entry.name!r} fails to import ({detail}): {entry.describe()}; "
                              f"fix or reinstall {entry.distribution}, or uninstall it") from None
        if not isinstance(target, type) or Tracker not in target.__mro__:
            raise PluginError(f"plug-in tracker type {entry.name!r}: the {entry.describe()} names {target!r}, not a subclass of "
                              f"scintrack.trackers.base.Tracker; point it at the tracker class (module:Class) and reinstall {entry.distribution}")
        current = _TYPES.get(entry.name)
        if current is not None and current.cls is not target:
            raise PluginError(f"plug-in tracker type {entry.name!r} of the {entry.describe()} clashes with the type registered by "
                              f"{current.cls.__module__}.{current.cls.__qualname__}; rename the entry point or the @register name and reinstall {entry.distribution}")
        try:
            register(entry.name)(target)
        except (TypeError, ValueError) as exc:
            raise PluginError(f"plug-in tracker type {entry.name!r} of the {entry.describe()} is not a complete tracker ({exc}); "
                              "see the Tracker protocol in scintrack/trackers/base.py and run scintrack.testing.check_tracker on it") from None
        _TYPES[entry.name] = replace(_TYPES[entry.name], plugin=entry)
        done.append(entry.name)
    return done


def _load_entry(entry):
    module = importlib.import_module(entry.module)
    attr = entry.value.partition(":")[2].strip()
    target = module
    for part in attr.split(".") if attr else ():
        target = getattr(target, part)
    return target


def _in_package(cls: type) -> bool:
    return cls.__module__.startswith(__name__.rpartition(".")[0] + ".")


def known_types() -> list[str]:
    _load()
    return sorted(_TYPES)


def get(type_name: str) -> TrackerType:
    _load()
    try:
        return _TYPES[type_name]
    except KeyError:
        raise ValueError(f"unknown tracker type {type_name!r} (known: {', '.join(known_types())})") from None


def from_package(type_name: str) -> bool:
    """True when the type is defined by a module of this package (not registered by a test or a plug-in)."""
    return _in_package(get(type_name).cls)


def plugin_of(type_name: str):
    """The entry point (:class:`scintrack.codeversion.PluginEntry`) of a plug-in type, None for any other type."""
    return get(type_name).plugin


def build(name: str, spec: Mapping[str, Any], context: TrackerContext) -> Tracker:
    """The tracker of config entry ``name`` (``spec = config["trackers"][name]``).

    The spec is validated against its type's fragment first (a spec that
    bypassed the config check, e.g. built in code, cannot carry keys its type
    ignores).
    """
    validate_specs({name: spec}, "the tracker spec")
    kind = get(spec["type"])
    try:
        return kind.from_spec(spec, context)
    except (ValueError, KeyError) as exc:
        raise ValueError(f"tracker {name!r} ({spec['type']}): {exc}") from exc


def label(name: str, spec: Mapping[str, Any]) -> str:
    """Plain-text label: the spec's ``label`` if given, else the type's default for this spec."""
    if "label" in spec:
        return str(spec["label"])
    return get(spec["type"]).label(name, spec)


def tracking_keys(spec: Mapping[str, Any]) -> tuple[str, ...]:
    """The ``config["tracking"]`` keys a tracker of this spec reads when it is built.

    A type may declare ``SPEC_OVERRIDES = {spec key: tracking key}``: a spec
    that sets the key does not read the shared value (a PLL with its own
    ``bandwidth_hz`` ignores ``tracking.pll_bandwidth_hz``), so changing the
    shared value does not rerun its experiments.
    """
    kind = get(spec["type"])
    overridden = {t for k, t in getattr(kind.cls, "SPEC_OVERRIDES", {}).items() if k in spec}
    return tuple(k for k in kind.tracking_keys if k not in overridden)


def spec_schema(type_name: str) -> dict[str, Any]:
    """The full JSON Schema (Draft 2020-12) of one spec of this type."""
    kind = get(type_name)
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "type": "object",
        "required": ["type"],
        "additionalProperties": False,
        "properties": {
            "type": {"const": type_name},
            "label": {"type": "string", "minLength": 1, "description": "plain-text label in figures and tables"},
            **kind.schema,
        },
    }


def _where(name: str, path) -> str:
    out = f"trackers.{name}"
    for item in path:
        out += f"[{item}]" if isinstance(item, int) else f".{item}"
    return out


def validate_specs(trackers: Mapping[str, Any], source: str = "config/config.yaml") -> None:
    """Check every tracker spec against its type's schema fragment.

    Raises :class:`scintrack.errors.ConfigError` with one line naming the key,
    the rule it breaks and where to fix it.
    """
    import jsonschema

    fix = f"fix it in {source} or your --configfile/--config overlay"
    for name, spec in trackers.items():
        if not isinstance(spec, Mapping) or "type" not in spec:
            raise ConfigError(f"invalid config value at 'trackers.{name}': a tracker needs a 'type' ({', '.join(known_types())}); {fix}")
        if spec["type"] not in known_types():
            raise ConfigError(
                f"invalid config value at 'trackers.{name}.type': unknown tracker type {spec['type']!r} (known: {', '.join(known_types())}); {fix}"
            )
        schema = spec_schema(spec["type"])
        error = jsonschema.exceptions.best_match(jsonschema.Draft202012Validator(schema).iter_errors(dict(spec)))
        if error is None:
            continue
        path = list(error.absolute_path)
        if error.validator == "additionalProperties" and not path:
            extra = sorted(set(spec) - set(schema["properties"]))
            allowed = ", ".join(sorted(schema["properties"]))
            raise ConfigError(
                f"invalid config value at '{_where(name, path + extra[:1])}': key not allowed for type {spec['type']!r} (allowed: {allowed}); {fix}"
            )
        description = error.schema.get("description") if isinstance(error.schema, Mapping) else None
        hint = f" ({description})" if description else ""
        raise ConfigError(f"invalid config value at '{_where(name, path)}': {error.message.splitlines()[0]}{hint}; {fix}")
