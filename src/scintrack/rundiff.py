"""Compare the results of two reproductions by value: is a change of code a change of the science?

``python -m scintrack.rundiff OLD NEW`` reads the NetCDF results under
``OLD/results`` and ``NEW/results`` (the same relative paths) and prints:

* **summary statistics against their intervals**: every variable ``V`` with
  ``V_lo`` and ``V_hi`` (95 % intervals: steady-state RMSEs, slip means, times
  in lock) and no time axis; for each, ``|V_new - V_old|`` over the old
  interval's half-width, how many new values lie outside the old interval,
  and the largest changes;
* **trials per tracker**: in every result with ``tracker`` and ``trial``
  dimensions, the trials whose per-trial statistics changed by more than
  ``--rtol`` (relative), and the slip counts (``slips``, ``slip_events``)
  that changed.

This is the tolerance for a change that only moves last bits (e.g. the
trackers' own trigonometry, ``docs/performance.md``): every summary statistic
stays inside its old interval, and no more trials move than a one-ulp change
of the input moves.
Files only in one run are listed, not compared.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr


@dataclass
class IntervalReport:
    """Summary statistics with a 95 % interval, old against new."""

    count: int = 0
    outside: int = 0
    largest: list[tuple[float, str, str, float, float]] = field(default_factory=list)  # per (file, var) its largest: (change / half-width, file, var, old, new)


@dataclass
class TrackerReport:
    """One tracker over every result that has it."""

    trials: int = 0
    moved: int = 0
    slip_counts_changed: int = 0


def result_pairs(old: Path, new: Path) -> tuple[list[tuple[str, Path, Path]], list[str]]:
    """(relative name, old file, new file) of the NetCDF results in both runs, and the names found in one only."""
    a = {p.relative_to(old).as_posix(): p for p in sorted((old / "results").rglob("*.nc"))}
    b = {p.relative_to(new).as_posix(): p for p in sorted((new / "results").rglob("*.nc"))}
    return [(k, a[k], b[k]) for k in sorted(a.keys() & b.keys())], sorted(a.keys() ^ b.keys())


def _add_intervals(rep: IntervalReport, name: str, da: xr.Dataset, db: xr.Dataset) -> None:
    """Every ``V`` of one result pair with ``V_lo``/``V_hi`` and no ``time`` dimension, new against the old interval."""
    for v in da.data_vars:
        if f"{v}_lo" not in da or f"{v}_hi" not in da or "time" in da[v].dims or v not in db:
            continue
        x, y = da[v].values.astype(float), db[v].values.astype(float)
        lo, hi = da[f"{v}_lo"].values.astype(float), da[f"{v}_hi"].values.astype(float)
        half = (hi - lo) / 2.0
        ok = np.isfinite(x) & np.isfinite(y) & (half > 0)
        if not ok.any():
            continue
        rep.count += int(ok.sum())
        rep.outside += int(((y[ok] < lo[ok]) | (y[ok] > hi[ok])).sum())
        r = np.abs(y[ok] - x[ok]) / half[ok]
        i = int(np.argmax(r))
        rep.largest.append((float(r[i]), name, str(v), float(x[ok][i]), float(y[ok][i])))


def _per_trial(values: np.ndarray, dims: tuple[str, ...]) -> np.ndarray:
    """``values`` as (anything, trials)."""
    axis = dims.index("trial")
    return np.moveaxis(values, axis, -1).reshape(-1, values.shape[axis])


def _add_trackers(out: dict[str, TrackerReport], da: xr.Dataset, db: xr.Dataset, rtol: float) -> None:
    """Per tracker of one result pair: trials whose per-trial float statistics changed beyond ``rtol``, changed slip counts."""
    if "tracker" not in da.dims or "trial" not in da.dims or da.sizes != db.sizes:
        return
    for tr in da["tracker"].values:
        rep = out.setdefault(str(tr), TrackerReport())
        xa, xb = da.sel(tracker=tr), db.sel(tracker=tr)
        n = xa.sizes["trial"]
        moved = np.zeros(n, dtype=bool)
        for v in xa.data_vars:
            if "trial" not in xa[v].dims or v not in xb:
                continue
            x, y = _per_trial(xa[v].values, xa[v].dims), _per_trial(xb[v].values, xb[v].dims)
            if xa[v].dtype.kind == "f":
                same = (x == y) | (np.isnan(x) & np.isnan(y))
                with np.errstate(all="ignore"):
                    rel = np.abs(x - y) / np.maximum(np.abs(x), np.abs(y))
                moved |= (~same & ~(rel <= rtol)).any(axis=0)
            elif v in ("slips", "slip_events"):
                rep.slip_counts_changed += int((x != y).sum())
        rep.trials += n
        rep.moved += int(moved.sum())


def compare(pairs, rtol: float = 1e-9, keep: int = 10) -> tuple[IntervalReport, dict[str, TrackerReport]]:
    """Both reports, each result pair opened once; ``keep``: the largest interval changes kept."""
    iv, trackers = IntervalReport(), {}
    for name, pa, pb in pairs:
        with xr.open_dataset(pa) as da, xr.open_dataset(pb) as db:
            _add_intervals(iv, name, da, db)
            _add_trackers(trackers, da, db, rtol)
    iv.largest = sorted(iv.largest, reverse=True)[:keep]
    return iv, trackers


def interval_report(pairs, keep: int = 10) -> IntervalReport:
    """Every ``V`` with ``V_lo``/``V_hi`` and no ``time`` dimension, new against the old interval (:func:`compare`)."""
    return compare(pairs, keep=keep)[0]


def tracker_report(pairs, rtol: float = 1e-9) -> dict[str, TrackerReport]:
    """Per tracker: trials whose per-trial float statistics changed beyond ``rtol``, and changed slip counts (:func:`compare`)."""
    return compare(pairs, rtol=rtol)[1]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m scintrack.rundiff", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("old", type=Path, help="folder of the old run (holds results/)")
    ap.add_argument("new", type=Path, help="folder of the new run")
    ap.add_argument("--rtol", type=float, default=1e-9, help="relative change of a per-trial statistic that counts as a moved trial")
    args = ap.parse_args(argv)
    for run in (args.old, args.new):
        if not (run / "results").is_dir():
            print(f"error: {run}: no results/ folder (give the folder a reproduction ran in)", file=sys.stderr)
            raise SystemExit(2)
    pairs, only = result_pairs(args.old, args.new)
    print(f"{len(pairs)} results in both runs; in one only: {only or 'none'}")
    iv, trackers = compare(pairs, args.rtol)
    print(f"summary statistics with a 95 % interval: {iv.count}; new value outside the old interval: {iv.outside}")
    for r, name, v, x, y in iv.largest:
        print(f"  {100 * r:6.1f} % of the half-width  {name} {v}: {x:.6g} -> {y:.6g}")
    print(f"trials per tracker (moved: a per-trial statistic changed by more than {args.rtol:g} relative):")
    for tr, rep in trackers.items():
        print(f"  {tr:24s} {rep.moved:6d} / {rep.trials:6d} trials moved, {rep.slip_counts_changed:5d} slip counts changed")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
