"""The project's one way to read YAML: PyYAML's safe loader on libyaml's parser, refusing duplicated keys.

PyYAML's ``CSafeLoader`` has the same constructor and resolver as ``SafeLoader``
(so the same values) and parses config.yaml about 10x faster; every Snakemake
start-up reads it.  Where PyYAML was built without libyaml the
pure-Python ``SafeLoader`` is used.

**Duplicated keys.**  YAML forbids a key twice in one mapping, but PyYAML
keeps the last value and drops the others silently (two ``experiments:``
blocks in a config would drop the first one's settings without a word).
:data:`SAFE_LOADER` is that loader with the constructor's
``construct_mapping`` checking each mapping's own keys, at any depth, by their
constructed values (so ``1`` and ``01``, or ``yes`` and ``true``, are the same
key): a repeat raises :class:`DuplicateKeyError`, a ``yaml.YAMLError`` whose
message names the key and the lines of both.  Only the parser is C code; the
constructor is PyYAML's Python ``SafeConstructor``, so the check costs one
pass over the keys the constructor visits anyway.  Keys brought in by a
``<<`` merge are not duplicates: the mapping's own keys override them, as
YAML specifies.

A module of its own, importing nothing of the package: a reader of YAML (the
dataset registry, the archive check) does not take the config module's
imports into its code version.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

import yaml
from yaml.constructor import ConstructorError

_BASE = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
_MERGE = "tag:yaml.org,2002:merge"


class DuplicateKeyError(ConstructorError):
    """A mapping holds one key twice; ``key``, ``line`` (1-based, the repeat) and ``first_line`` say where."""

    def __init__(self, key: Any, node: yaml.Node, first: yaml.Node) -> None:
        self.key, self.line, self.first_line = key, node.start_mark.line + 1, first.start_mark.line + 1
        super().__init__(None, None, f"duplicate key {key!r} (first on line {self.first_line}, again on line {self.line})", node.start_mark)


class UniqueKeySafeLoader(_BASE):  # type: ignore[misc, valid-type]
    """The safe loader (libyaml's parser where PyYAML has it) with :class:`DuplicateKeyError` for a repeated key."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        if isinstance(node, yaml.MappingNode):
            seen: dict[Any, yaml.Node] = {}
            for key_node, _ in node.value:
                if key_node.tag == _MERGE:
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    first = seen.setdefault(key, key_node)
                except TypeError:  # an unhashable key: the constructor below reports it
                    continue
                if first is not key_node:
                    raise DuplicateKeyError(key, key_node, first)
        return super().construct_mapping(node, deep=deep)


#: the loader every YAML file of the project is read with
SAFE_LOADER = UniqueKeySafeLoader


def yaml_load(text: str | bytes) -> Any:
    """``yaml.safe_load(text)`` with :data:`SAFE_LOADER`: the same values, and a :class:`DuplicateKeyError` for a repeated key."""
    return yaml.load(text, Loader=SAFE_LOADER)  # noqa: S506 (a safe loader)


def deep_merge(base: Mapping[str, Any], overlay: Mapping[str, Any]) -> dict[str, Any]:
    """Recursive dict merge, as Snakemake merges ``--configfile`` overlays."""
    out = copy.deepcopy(dict(base))
    for key, value in overlay.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = deep_merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out
