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
the config), with the same effect.  Figures drawn from the synthetic
SKYDEL-like dataset (Zhao et al.'s paper) get ``_synthetic``.  Products of the
real GPS recordings (:data:`REAL_PAPER`, data kind "real") get ``_real`` on
every file stem, figures and tables alike.

A figure also declares what the gallery (:mod:`scintrack.products.gallery`)
shows beside it: the paper's figure number (``number``; None for a figure the
paper does not have), the paper's caption or claim in one line (``claim``),
the tables whose cells it draws (``tables``, linked on the comparison page)
and a ``verdict`` function: called with the same opened inputs and keyword
arguments as the figure function, it returns a :class:`Verdict`, the status
and one line with the number it rests on.  The figure rule writes it, with
the data kind and the layout check's problems, to ``<stem>.json`` beside the
figure.
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
    "scintrack.products.tables.susi_2014_readings",  # Susi readings U1-U4 of eqs. (7)-(8)
    "scintrack.products.figures.ranking",
    "scintrack.products.tables.ranking",
    "scintrack.products.figures.vila_valls_2018_aekf",
    "scintrack.products.tables.vila_valls_2018_aekf",
    "scintrack.products.figures.real_signals",
    "scintrack.products.tables.real_signals",
)

#: Report category of each paper (``Product.paper`` -> title).
PAPERS = {
    "vila_valls_2018": "Vila-Valls 2018", "zhao_jamming": "Zhao et al. (wideband jamming)", "susi_2014": "Susi et al. 2014",
    "cross_paper": "All trackers on all scenarios", "real_signals": "Real GPS recordings",
}
#: the report category of the real GPS recordings (no paper): its products are drawn from real data
REAL_PAPER = "real_signals"

Config = Mapping[str, Any]

#: what a figure's verdict can say
VERDICT_STATUSES = ("reproduced", "differs", "not reproduced", "no paper figure")

#: the data a product is drawn from (:data:`scintrack.products.figures.conventions.DATA_WORDS`)
DATA_KINDS = ("synthetic CSM", "surrogate", "synthetic SKYDEL-like", "real", "mixed")


@dataclass(frozen=True)
class Verdict:
    """A figure's verdict: ``status`` (one of :data:`VERDICT_STATUSES`) and one line saying it with its number."""

    status: str
    text: str

    def __post_init__(self):
        if self.status not in VERDICT_STATUSES:
            raise ValueError(f"verdict status {self.status!r} is not one of {', '.join(VERDICT_STATUSES)}")


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
    number: str | None = None
    claim: str = ""
    tables: tuple[str, ...] = ()
    verdict: Callable[..., Verdict] | None = field(default=None, repr=False)

    @property
    def module(self) -> str:
        return self.function.__module__

    def is_surrogate(self, config: Config) -> bool:
        from ..pipeline.paths import trace_source

        if self.surrogate is not None:
            return bool(self.surrogate(config))
        return self.trace and trace_source(config) == "surrogate"

    def data_kind(self, config: Config) -> str:
        """What the product is drawn from (one of :data:`DATA_KINDS`)."""
        if self.paper == "cross_paper":
            return "mixed"
        if self.paper == REAL_PAPER:
            return "real"
        if self.paper == "zhao_jamming":
            return "synthetic SKYDEL-like"
        if self.trace or self.surrogate is not None:
            return "surrogate" if self.is_surrogate(config) else "real"
        return "synthetic CSM"

    def suffix(self, config: Config) -> str:
        if self.is_surrogate(config):
            return "_surrogate"
        if self.paper == REAL_PAPER:
            return "_real"
        return "_synthetic" if self.kind == "figure" and self.data_kind(config) == "synthetic SKYDEL-like" else ""

    def outputs(self, config: Config) -> dict[str, str]:
        """Output key -> path: ``pdf``/``png`` for a figure, ``<stem>_csv``/``<stem>_md`` for a table."""
        folder = f"{self.kind}s/{self.paper}"
        sfx = self.suffix(config)
        if self.kind == "figure":
            (stem,) = self.stems
            return {ext: f"{folder}/{stem}{sfx}.{ext}" for ext in ("pdf", "png", "json")}
        return {f"{stem}_{ext}": f"{folder}/{stem}{sfx}.{ext}" for stem in self.stems for ext in ("csv", "md")}


_REGISTRY: dict[str, Product] = {}


def _register(product: Product) -> None:
    old = _REGISTRY.get(product.name)
    if old is not None and (old.module, old.function.__qualname__) != (product.module, product.function.__qualname__):
        raise ValueError(f"product {product.name!r} is registered twice ({old.module} and {product.module})")
    _REGISTRY[product.name] = product


def figure(name: str, stem: str, *, paper: str, section: str, inputs: Callable[[Config], dict[str, str]],
           kwargs: Callable[[Config], dict[str, Any]] = _no_kwargs, trace: bool = False, surrogate: Callable[[Config], bool] | None = None,
           number: str | None = None, claim: str = "", tables: tuple[str, ...] = (), verdict: Callable[..., Verdict] | None = None):
    """Register a figure function (decorator)."""

    def decorate(func):
        _register(Product(name, "figure", func, (stem,), inputs, kwargs, paper, section, trace, surrogate, number, claim,
                          tuple(tables), verdict))
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
