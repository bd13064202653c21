"""Display names of trackers, read from the results that name them.

The tracker modules own their labels (:func:`scintrack.trackers.registry.label`);
the experiment runners store them in every result as the attribute
``tracker_labels`` (JSON ``{config name: label}``), so figures and tables
show what the result was computed with and never keep a list of their own.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import xarray as xr


def tracker_labels(ds: xr.Dataset) -> dict[str, str]:
    raw = ds.attrs.get("tracker_labels")
    if raw is None:
        raise KeyError("this result has no 'tracker_labels' attribute (computed by an older version); rerun its rule")
    return json.loads(raw)


def tex(label: str) -> str:
    """The same label with mathtext subscripts for figures (S4 -> S$_4$)."""
    return label.replace("S4", "S$_4$")


def tracker_label(ds: xr.Dataset, name: str, *, for_figure: bool = False) -> str:
    label = tracker_labels(ds).get(str(name), str(name))
    return tex(label) if for_figure else label
