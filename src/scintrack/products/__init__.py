"""The papers' figures and tables: the registry (:mod:`.registry`), one module per paper in
:mod:`.figures` and :mod:`.tables`, and the table of every workflow rule (:mod:`.rules_table`)."""

from .registry import PAPERS, PRODUCT_MODULES, Product, figure, get, products, table

__all__ = ["PAPERS", "PRODUCT_MODULES", "Product", "figure", "get", "products", "table"]
