"""Code versions from the code, not its bytes.

One mechanism for the two places where a result must follow the code that
made it: the ``code`` param of every Snakemake rule (so editing a module
reruns exactly the rules that import it) and the version of a generated
dataset (:mod:`scintrack.data.versioning`).

* :func:`normalised_source` is the module's abstract syntax tree without
  docstrings, line numbers or comments (``ast.dump``), so comments,
  formatting and documentation do not change a version; any change of what
  the code does does.
* :func:`import_closure` follows the ``scintrack`` imports of a module or a
  script (top level and inside functions, absolute and relative) to every
  module it can reach, so a rule's hash covers what it actually runs without a
  hand-kept list.
* :func:`code_version` hashes the normalised sources of that closure.

One module imports modules it does not name: the tracker registry imports
every module of its package at run time (a new tracker registers itself by
existing).  :data:`DISCOVERS` says so, and the closure of any rule that
reaches the registry holds the whole package.

Plug-in tracker types (:data:`PLUGIN_GROUP`, ``docs/adding-a-tracker.md``)
live in other installed distributions, outside any closure.
:func:`plugin_entry_points` lists them from the installed metadata without
importing them, and :func:`plugin_code` gives, for the tracker types a rule
runs, each plug-in's distribution name, version and the SHA-256 of the
normalised sources of its package (the same normaliser); :func:`with_plugins`
appends them to a code version, so editing a plug-in reruns exactly the rules
that run one of its types, and the result's ``code_version`` names it.

The dump depends on the Python version's AST, so a different interpreter
gives different versions (reruns, never stale results); the locked
environment fixes the interpreter.

Speed (every rule's ``code`` param is computed when Snakemake builds the
DAG): what a file contributes, the SHA-256 of its normalised
source and the modules it imports, is kept in a small JSON cache keyed by
the SHA-256 of the file's *bytes* (and the interpreter version), in
``.snakemake/scintrack-code-cache.json`` of the working directory when that
folder exists (``$SCINTRACK_CODE_CACHE`` names another file; empty: no disk
cache).  A changed file has other bytes, so a cache entry can never be stale;
a hit skips parsing.  The cache is written atomically (temporary file, then
rename), so concurrent jobs cannot corrupt it.

The same cache remembers what a pure function of the code and of a JSON value
returned (:func:`remembered`), keyed by the code version of the module that
computes it: the config's consistency check and the tracking keys of a
tracker spec need the tracker modules (numba) and xarray, which building the
DAG then loads only when the code or the config changed.
"""

from __future__ import annotations

import ast
import hashlib
import json
import os
import re
import sys
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

PACKAGE = "scintrack"
#: module -> package whose every module it imports at run time (not visible as an import statement)
DISCOVERS = {"scintrack.trackers.registry": "scintrack.trackers"}
ROOT = Path(__file__).resolve().parent


@cache
def module_file(name: str) -> Path | None:
    """Source file of a ``scintrack`` module or package name (None if there is none)."""
    if name != PACKAGE and not name.startswith(PACKAGE + "."):
        return None
    parts = name.split(".")[1:]
    if not parts:
        return ROOT / "__init__.py"
    rel = Path(*parts)
    for candidate in (ROOT / rel.with_suffix(".py"), ROOT / rel / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _module_name(path: Path) -> str | None:
    try:
        rel = path.resolve().relative_to(ROOT)
    except ValueError:
        return None
    parts = list(rel.with_suffix("").parts)
    if parts and parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join([PACKAGE, *parts])


def _strip_docstrings(tree: ast.AST) -> ast.AST:
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str):
                node.body = body[1:] or [ast.Pass()]
    return tree


@cache
def _parse(path: str) -> ast.Module:
    """The file's syntax tree without docstrings (parsed once; imports are unaffected by the stripping)."""
    return _strip_docstrings(ast.parse(Path(path).read_text(encoding="utf-8"), filename=path))


@cache
def normalised_source(path: str | Path) -> str:
    """``ast.dump`` of a file without docstrings and positions (comments never reach the AST)."""
    return ast.dump(_parse(str(path)), include_attributes=False)


def clear_caches() -> None:
    """Forget parsed sources (for a process that edits them, e.g. a test)."""
    _parse.cache_clear()
    normalised_source.cache_clear()
    _facts_cached.cache_clear()
    module_file.cache_clear()
    _module_version.cache_clear()
    _plugin_entries.cache_clear()


def clear_disk_cache_memory() -> None:
    """Forget the in-memory copy of the disk cache (it is read again on next use)."""
    _DISK.clear()
    _DISK_STATE.clear()


_DISK: dict[str, dict] = {}
_DISK_STATE: dict[str, object] = {}
_TAG = f"py{sys.version_info[0]}.{sys.version_info[1]}"


def _cache_file() -> Path | None:
    env = os.environ.get("SCINTRACK_CODE_CACHE")
    if env is not None:
        return Path(env) if env else None
    folder = Path.cwd() / ".snakemake"
    return folder / "scintrack-code-cache.json" if folder.is_dir() else None


def _disk() -> dict[str, dict]:
    if "loaded" not in _DISK_STATE:
        _DISK_STATE["loaded"] = True
        _DISK_STATE["dirty"] = False
        path = _cache_file()
        _DISK_STATE["path"] = path
        if path is not None and path.is_file():
            try:
                data = json.loads(path.read_text(encoding="utf-8"))
                if isinstance(data, dict):
                    _DISK.update({k: v for k, v in data.items() if isinstance(v, dict)})
            except (OSError, ValueError):
                pass  # an unreadable cache is only a miss
    return _DISK


def _save_disk() -> None:
    path = _DISK_STATE.get("path")
    if not _DISK_STATE.get("dirty") or path is None:
        return
    from .atomic import OutputWriteError, atomic_bytes

    try:
        atomic_bytes(path, json.dumps(_DISK, sort_keys=True), hold=False)  # bookkeeping, not an output: no fault-injection hold
        _DISK_STATE["dirty"] = False
    except (OSError, OutputWriteError):
        pass  # no cache written (a full disk, a file-size limit): the next run parses again


def _facts(path: Path, own_name: str | None) -> dict:
    """``{"digest": sha256 of the normalised source, "imports": [...]}`` of a file, via the disk cache."""
    raw = Path(path).read_bytes()
    key = f"{_TAG}:{own_name or ''}:{hashlib.sha256(raw).hexdigest()}"
    disk = _disk()
    hit = disk.get(key)
    if hit is not None and isinstance(hit.get("digest"), str) and isinstance(hit.get("imports"), list):
        return hit
    facts = {"digest": hashlib.sha256(normalised_source(path).encode()).hexdigest(), "imports": sorted(_parsed_imports(Path(path), own_name))}
    disk[key] = facts
    _DISK_STATE["dirty"] = True
    return facts


@cache
def _facts_cached(path: Path, own_name: str | None) -> tuple[str, frozenset[str]]:
    f = _facts(path, own_name)
    return f["digest"], frozenset(f["imports"])


def _imports(path: Path, own_name: str | None) -> frozenset[str]:
    """``scintrack`` modules imported anywhere in a file (``from a import b`` also tries ``a.b``)."""
    return _facts_cached(Path(path), own_name)[1]


def source_digest(path: Path, own_name: str | None = None) -> str:
    """SHA-256 of :func:`normalised_source` of a file (cached, see the module docstring)."""
    return _facts_cached(Path(path), own_name)[0]


def _parsed_imports(path: Path, own_name: str | None) -> frozenset[str]:
    """:func:`_imports` from the syntax tree itself."""
    package = None
    if own_name is not None:
        package = own_name if path.name == "__init__.py" else own_name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(_parse(str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                if package is None:
                    continue
                base_parts = package.split(".")
                base_parts = base_parts[: len(base_parts) - (node.level - 1)]
                base = ".".join(base_parts + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return frozenset(name for name in found if module_file(name) is not None)


def _with_parents(name: str) -> set[str]:
    """A module and the packages above it (their ``__init__`` runs on import)."""
    parts = name.split(".")
    return {".".join(parts[:i]) for i in range(1, len(parts) + 1)}


def _package_modules(package: str) -> list[str]:
    folder = module_file(package).parent
    return [f"{package}.{p.stem}" for p in sorted(folder.glob("*.py")) if p.stem != "__init__"]


def import_closure(entries: Iterable[str | Path]) -> list[str]:
    """Every ``scintrack`` module reachable from ``entries`` (module names or script/module paths)."""
    todo: list[str] = []
    for entry in entries:
        if isinstance(entry, Path) or str(entry).endswith(".py"):
            path = Path(entry)
            name = _module_name(path)
            if name is None:  # a script outside the package: only its imports count
                todo.extend(_imports(path, None))
                continue
            todo.append(name)
        else:
            if module_file(str(entry)) is None:
                raise ValueError(f"{entry!r} is not a module of the {PACKAGE} package")
            todo.append(str(entry))
    seen: set[str] = set()
    while todo:
        name = todo.pop()
        for mod in _with_parents(name):
            if mod in seen:
                continue
            seen.add(mod)
            todo.extend(_imports(module_file(mod), mod))
            if mod in DISCOVERS:
                todo.extend(_package_modules(DISCOVERS[mod]))
    return sorted(seen)


def code_version(entries: Iterable[str | Path], length: int = 16) -> str:
    """Hash of the normalised sources of the import closure of ``entries``.

    Scripts outside the package (``workflow/scripts/*.py``) contribute their
    own normalised source as well as their imports.
    """
    entries = list(entries)
    h = hashlib.sha256()
    for entry in entries:
        if (isinstance(entry, Path) or str(entry).endswith(".py")) and _module_name(Path(entry)) is None:
            h.update(b"script\0" + source_digest(Path(entry)).encode())
    for name in import_closure(entries):
        h.update(name.encode() + b"\0" + source_digest(module_file(name), name).encode())
    _save_disk()
    return h.hexdigest()[:length]


@cache
def _module_version(module: str) -> str:
    """:func:`code_version` of one module (once per process, like the parsed sources; :func:`clear_caches` forgets it)."""
    return code_version([module])


def remembered(module: str, name: str, arg: Any, compute: Callable[[], Any], keep: Callable[[], bool] | None = None) -> Any:
    """``compute()``, a pure function of ``arg`` and of the code of ``module``'s import closure, remembered in the disk cache.

    The entry is keyed by ``name``, :func:`code_version` of ``module`` (so any
    change of the code it runs is a miss) and the SHA-256 of ``arg`` as
    canonical JSON; ``compute()`` must return a JSON value.  An exception
    propagates and nothing is remembered (an error is raised afresh on every
    call); an ``arg`` that is not JSON is never remembered, nor a value for
    which ``keep()`` (asked after ``compute()``) is false: code outside the
    closure took part (a tracker type registered by a test or a plug-in).
    Without a disk cache (see the module docstring) every call computes.
    """
    try:
        text = json.dumps(arg, sort_keys=True, separators=(",", ":"))
    except (TypeError, ValueError):
        return compute()
    key = f"{_TAG}:remembered:{name}:{_module_version(module)}:{hashlib.sha256(text.encode()).hexdigest()}"
    disk = _disk()
    hit = disk.get(key)
    if hit is not None and "value" in hit:
        return hit["value"]
    value = compute()
    if _DISK_STATE.get("path") is not None and (keep is None or keep()):
        disk[key] = {"value": value}
        _DISK_STATE["dirty"] = True
        _save_disk()
    return value


# --- plug-in tracker types: code outside the package ---------------------------------

#: entry-point group of plug-in tracker types: ``<type name> = <module>:<class>``
PLUGIN_GROUP = "scintrack.trackers"


@dataclass(frozen=True)
class PluginEntry:
    """One entry point of :data:`PLUGIN_GROUP`: the tracker type ``name``, its target and its distribution."""

    name: str
    value: str
    distribution: str
    version: str

    @property
    def module(self) -> str:
        return self.value.partition(":")[0].strip()

    def describe(self) -> str:
        """``entry point 'name = value' of <distribution> <version>`` (for messages)."""
        return f"entry point '{self.name} = {self.value}' of {self.distribution} {self.version}"


def _normalised_name(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


@cache
def _plugin_entries(path: tuple[str, ...]) -> tuple[PluginEntry, ...]:
    import importlib.metadata as md

    seen: set[str] = set()
    out = []
    for dist in md.distributions(path=list(path)):
        name = dist.metadata["Name"] or ""
        key = _normalised_name(name)
        if key in seen:  # a distribution found again later on the path is shadowed, as its modules are
            continue
        seen.add(key)
        for ep in dist.entry_points:
            if ep.group == PLUGIN_GROUP:
                out.append(PluginEntry(name=ep.name, value=ep.value, distribution=name, version=str(dist.version)))
    return tuple(sorted(out, key=lambda e: (e.name, _normalised_name(e.distribution))))


def plugin_entry_points(path: Sequence[str] | None = None) -> tuple[PluginEntry, ...]:
    """Every entry point of :data:`PLUGIN_GROUP` of the distributions on ``path`` (default ``sys.path``), by type name.

    Read from the installed metadata, nothing imported.  A distribution installed twice counts
    once, the copy earlier on the path (the one whose modules import).  Two distributions may
    declare the same name: both are listed (the registry refuses the clash).
    """
    return _plugin_entries(tuple(str(p) for p in (sys.path if path is None else path)))


def plugin_files(entry: PluginEntry, path: Sequence[str] | None = None) -> list[tuple[str, Path]]:
    """(name inside the plug-in, file) of every module of the top-level package of ``entry``'s module.

    Found by the import system's finders without importing (``path``: search these folders only).
    Raises :class:`~scintrack.errors.ConfigError` when the module is not installed.
    """
    import importlib.machinery
    import importlib.util

    from .errors import ConfigError

    top = entry.module.split(".")[0]
    try:
        spec = importlib.machinery.PathFinder.find_spec(top, list(path)) if path is not None else importlib.util.find_spec(top)
    except (ImportError, ValueError):
        spec = None
    if spec is None or (spec.origin is None and not spec.submodule_search_locations):
        raise ConfigError(f"plug-in tracker type {entry.name!r}: module {entry.module!r} of its {entry.describe()} is not installed; "
                          f"reinstall {entry.distribution} (pip install ...) or uninstall it")
    if spec.submodule_search_locations:
        files = []
        for folder in map(Path, spec.submodule_search_locations):
            files += [(f"{top}/{p.relative_to(folder).as_posix()}", p) for p in folder.rglob("*.py") if "__pycache__" not in p.parts]
        return sorted(files)
    return [(Path(spec.origin).name, Path(spec.origin))]


def plugin_source_sha256(entry: PluginEntry, path: Sequence[str] | None = None) -> str:
    """SHA-256 over the names and :func:`normalised_source` digests of :func:`plugin_files` (comments and docstrings do not count)."""
    h = hashlib.sha256()
    for name, file in plugin_files(entry, path):
        h.update(name.encode() + b"\0" + source_digest(file).encode() + b"\n")
    return h.hexdigest()


def plugin_code(types: Iterable[str], path: Sequence[str] | None = None) -> list[dict[str, str]]:
    """What of the tracker ``types`` is plug-in code: one record per plug-in type among them, sorted by type.

    ``{"type", "entry_point", "distribution", "version", "source_sha256"}``; built-in types give
    nothing, so a rule without plug-in types has the code version it has without plug-ins.
    """
    wanted = set(types)
    out = []
    for entry in plugin_entry_points(path):
        if entry.name in wanted:
            out.append({"type": entry.name, "entry_point": f"{entry.name} = {entry.value}", "distribution": entry.distribution,
                        "version": entry.version, "source_sha256": plugin_source_sha256(entry, path)})
    _save_disk()
    return out


def describe_plugins(records: Iterable[dict[str, str]]) -> str:
    """``"<distribution> <version> (source sha256 <16 hex>)"`` of each distribution in ``records``, joined by ``"; "``."""
    seen = dict.fromkeys(f"{r['distribution']} {r['version']} (source sha256 {r['source_sha256'][:16]})" for r in records)
    return "; ".join(sorted(seen))


def with_plugins(version: str, records: Sequence[dict[str, str]]) -> str:
    """A code version with the plug-in code of ``records`` (:func:`plugin_code`): ``version`` itself without any,
    else ``"<version> + plug-ins: <describe_plugins>"``."""
    return f"{version} + plug-ins: {describe_plugins(records)}" if records else version
