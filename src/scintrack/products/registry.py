"""Registry of the papers' figures and tables, declared next to their functions.

A figure or table function is registered with a decorator that says what the
workflow needs to know about it: its rule name (``fig07``, ``table03``), its
output file stem(s), its inputs by keyword (result paths, as a function of the
config, from :mod:`scintrack.pipeline.paths`), extra keyword arguments taken
from the config, and where it sits in the report.  The rules in
``workflow/rules/figures.smk`` and ``tables.smk`` are generated from this
registry; the render scripts find the function through it, so a function is
referenced by import (the decorator sits on it), never by a name string.

Figure functions receive the opened inputs by keyword plus ``kwargs`` and
return a matplotlib Figure.  Table functions receive the opened inputs in the
declared order and return ``{stem: (DataFrame, title, note)}``.

Sec. VI-E outputs (``trace=True``) get ``_surrogate`` appended to every file
stem when the traces are the synthetic surrogate; a product that reads other
traces (Susi 2014's) says when it does with ``surrogate=`` (a function of
the config), with the same effect.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

# One line per paper module that registers products.
PRODUCT_MODULES = (
    "scintrack.products.figures.vila_valls_2018",
    "scintrack.products.figures.vila_valls_2018_traces",
    "scintrack.products.tables.vila_valls_2018",
    "scintrack.products.tables.vila_valls_2018_traces",
    "scintrack.products.figures.zhao_jamming",
    "scintrack.products.figures.zhao_receiver",
    "scintrack.products.tables.zhao_jamming",
    "scintrack.products.figures.susi_2014",
    "scintrack.products.tables.susi_2014",
    "scintrack.products.figures.ranking",
    "scintrack.products.tables.ranking",
    "scintrack.products.figures.vila_valls_2018_aekf",
    "scintrack.products.tables.vila_valls_2018_aekf",
)

#: Report category of each paper (``Product.paper`` -> title).
PAPERS = {
    "vila_valls_2018": "Vila-Valls 2018", "zhao_jamming": "Zhao et al. (wideband jamming)", "susi_2014": "Susi et al. 2014",
    "cross_paper": "All trackers on all scenarios",
}

Config = Mapping[str, Any]


def _no_kwargs(config: Config) -> dict[str, Any]:
    return {}


@dataclass(frozen=True)
class Product:
    name: str
    kind: str  # "figure" | "table"
    function: Callable = field(repr=False)
    stems: tuple[str, ...]
    inputs: Callable[[Config], dict[str, str]] = field(repr=False)
    kwargs: Callable[[Config], dict[str, Any]] = field(repr=False)
    paper: str
    section: str
    trace: bool = False
    surrogate: Callable[[Config], bool] | None = field(default=None, repr=False)

    @property
    def module(self) -> str:
        return self.function.__module__

    def suffix(self, config: Config) -> str:
        from ..pipeline.paths import trace_source

        if self.surrogate is not None:
            return "_surrogate" if self.surrogate(config) else ""
        return "_surrogate" if self.trace and trace_source(config) == "surrogate" else ""

    def outputs(self, config: Config) -> dict[str, str]:
        """Output key -> path: ``pdf``/``png`` for a figure, ``<stem>_csv``/``<stem>_md`` for a table."""
        folder = f"{self.kind}s/{self.paper}"
        sfx = self.suffix(config)
        if self.kind == "figure":
            (stem,) = self.stems
            return {ext: f"{folder}/{stem}{sfx}.{ext}" for ext in ("pdf", "png")}
        return {f"{stem}_{ext}": f"{folder}/{stem}{sfx}.{ext}" for stem in self.stems for ext in ("csv", "md")}


_REGISTRY: dict[str, Product] = {}


def _register(product: Product) -> None:
    old = _REGISTRY.get(product.name)
    if old is not None and (old.module, old.function.__qualname__) != (product.module, product.function.__qualname__):
        raise ValueError(f"product {product.name!r} is registered twice ({old.module} and {product.module})")
    _REGISTRY[product.name] = product


def figure(name: str, stem: str, *, paper: str, section: str, inputs: Callable[[Config], dict[str, str]],
           kwargs: Callable[[Config], dict[str, Any]] = _no_kwargs, trace: bool = False, surrogate: Callable[[Config], bool] | None = None):
    """Register a figure function (decorator)."""

    def decorate(func):
        _register(Product(name, "figure", func, (stem,), inputs, kwargs, paper, section, trace, surrogate))
        return func

    return decorate


def table(name: str, stems: tuple[str, ...] | list[str], *, paper: str, section: str, inputs: Callable[[Config], dict[str, str]],
          trace: bool = False, surrogate: Callable[[Config], bool] | None = None):
    """Register a table function (decorator)."""

    def decorate(func):
        _register(Product(name, "table", func, tuple(stems), inputs, _no_kwargs, paper, section, trace, surrogate))
        return func

    return decorate


def products(kind: str | None = None) -> dict[str, Product]:
    """Every registered product (of one kind), in registration order."""
    for module in PRODUCT_MODULES:
        importlib.import_module(module)
    return {k: p for k, p in _REGISTRY.items() if kind is None or p.kind == kind}


def get(name: str, module: str | None = None) -> Product:
    """The product ``name``; with ``module`` (its function's module, as the rules
    pass it) only that module is imported, which keeps a render job light."""
    if module is not None:
        importlib.import_module(module)
        if name in _REGISTRY and _REGISTRY[name].module == module:
            return _REGISTRY[name]
    found = products().get(name)
    if found is None:
        raise KeyError(f"no figure or table named {name!r}; known: {', '.join(products())}")
    return found
