"""Susi et al. 2014: the readings U1-U4 of eqs. (7)-(8), each with its loop, its jitter and the pre-declared verdict.

``susi_table_readings`` (experiment ``susi_readings``; the readings and the criterion are declared in
``docs/REPRODUCTION.md``, "Susi et al. 2014: what eqs. (7)-(8) put into the SAKF's process noise"):

* per scenario and tracker (the 15-Hz PLL, the AKF and one SAKF per reading, spec key
  ``scintillation_q_reading``): the median on-line T, p and weight w of the reading's run, the scintillation
  PSDs it adds at them and the noise bandwidth of its steady-state gain (rule ``susi_readings_loops``,
  :mod:`scintrack.experiments.susi_readings`), the discriminator and true tracking-error jitter with 95 %
  intervals, and the paired differences to the PLL and to the AKF (the jitter helpers of
  :mod:`.susi_2014`);
* per reading the criterion: in a scenario the reading *holds* on a metric when its SAKF minus the PLL and
  minus the AKF both have their paired 95 % interval below 0 (:func:`.susi_2014.verdict`).  The reading
  **explains** the chapter when that holds on the discriminator jitter in both scenarios, **explains part**
  when it holds on the discriminator jitter in one scenario, or only on the tracking-error jitter (in both),
  and otherwise **does not explain** it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from ...labels import tracker_labels
from ...pipeline import paths
from ..registry import table
from .susi_2014 import (
    AKF,
    METRIC_TEXT,
    METRICS,
    PAPER,
    REFERENCE,
    SECTION,
    _data_title,
    _jitter_method,
    _scenario_notes,
    any_surrogate,
    ci,
    experiment_scenarios,
    fmt_ci,
    has_jitter,
    paired,
    short_source,
    trial_jitter,
    verdict,
)

if TYPE_CHECKING:
    import xarray as xr

READINGS = "susi_readings"  # the experiment (pipeline.params.SUSI_READINGS_EXPERIMENT)
LOOPS_PRODUCT = "susi_readings_loops"  # the ``product`` attribute of results/susi_2014/readings_loops.nc
#: reading key (scintillation_q_reading) -> its name in the pre-declared table
READING_TEXT = {
    "literal_cycles": "U1 as declared (literal, eq. 8 / (2 pi)^2)",
    "literal": "U1 fixed (literal, rad-consistent; the SAKF default)",
    "eq8_only": "U2 (eq. 8 alone)",
    "freq_random_walk": "U3 (frequency random walk)",
    "increment_variance": "U4 (1-ms increment variance)",
    "none": "",
}
VERDICTS = ("explains", "explains part", "does not explain")


def _inputs(config) -> dict[str, str]:
    """The readings' results (config order), then their loops (rule susi_readings_loops)."""
    from ...pipeline.params import SUSI_READINGS_LOOPS

    out = {f"{READINGS}__{sc}": paths.exp_result(READINGS, sc) for sc in experiment_scenarios(config, READINGS)}
    return {**out, "loops": SUSI_READINGS_LOOPS} if out else out


def _surrogate(config) -> bool:
    return any_surrogate(config, experiment_scenarios(config, READINGS))


def is_loops(ds: xr.Dataset) -> bool:
    return ds.attrs.get("product") == LOOPS_PRODUCT


def _loop_value(loops: xr.Dataset | None, scenario: str, tracker: str, var: str) -> float:
    if loops is None or scenario not in loops["scenario"].values or tracker not in loops["tracker"].values:
        return np.nan
    return float(loops[var].sel(scenario=scenario, tracker=tracker))


def _reading(loops: xr.Dataset | None, tracker: str) -> str:
    if loops is None or tracker not in loops["tracker"].values:
        return "none"
    return str(loops["reading"].sel(tracker=tracker).values)


def readings_long(results: Sequence[xr.Dataset], loops: xr.Dataset | None) -> pd.DataFrame:
    """One row per scenario x tracker: the loop of the reading, each metric's jitter and its paired differences to
    the PLL and the AKF, and whether the criterion's condition holds there (:func:`.susi_2014.verdict`)."""
    rows = []
    for res in results:
        sc = str(res.attrs["scenario"])
        label = tracker_labels(res)
        for tr in (str(t) for t in res["tracker"].values):
            if not has_jitter(res, tr):
                continue
            reading = _reading(loops, tr)
            row = {"scenario": sc, "data": short_source(res), "tracker": tr, "label": label.get(tr, tr), "reading": reading,
                   "reading_text": READING_TEXT.get(reading, reading), "trials": int(res["n_trials"])}
            for var in ("T_median", "p_median", "weight_median", "s_phi", "s_f", "bandwidth_hz", "bandwidth_weighted_hz"):
                row[var] = _loop_value(loops, sc, tr, var)
            for metric in METRICS:
                v = trial_jitter(res, tr, metric)
                row.update(dict(zip((f"{metric}_jitter_rad", f"{metric}_ci95_lo", f"{metric}_ci95_hi"), ci(v))))
                ivs = []
                for ref, key in ((REFERENCE, "pll"), (AKF, "akf")):
                    iv = paired(v, trial_jitter(res, ref, metric)) if tr not in (REFERENCE, AKF) and has_jitter(res, ref) else (np.nan,) * 3
                    row.update(dict(zip((f"{metric}_minus_{key}_rad", f"{metric}_minus_{key}_ci95_lo", f"{metric}_minus_{key}_ci95_hi"), iv)))
                    ivs.append(iv)
                row[f"{metric}_below_pll_and_akf"] = verdict(ivs) if tr not in (REFERENCE, AKF) else ""
            rows.append(row)
    return pd.DataFrame(rows)


def reading_verdict(disc: Sequence[str], track: Sequence[str]) -> str:
    """The pre-declared verdict of one reading from its per-scenario conditions (:func:`.susi_2014.verdict`
    strings) on the discriminator jitter (``disc``) and the tracking-error jitter (``track``)."""
    if any(v.startswith("not evaluated") for v in (*disc, *track)) or not disc:
        return "not evaluated"
    n_disc = sum(v == "holds" for v in disc)
    if n_disc == len(disc) and len(disc) >= 2:
        return "explains"
    if n_disc >= 1 or all(v == "holds" for v in track):
        return "explains part"
    return "does not explain"


def verdict_frame(long: pd.DataFrame) -> pd.DataFrame:
    """One row per reading: its condition per scenario and metric, and its verdict."""
    rows = []
    sakf = long[long["reading"] != "none"]
    for (tr, reading), grp in sakf.groupby(["tracker", "reading"], sort=False):
        row = {"reading": READING_TEXT.get(reading, reading), "tracker": grp["label"].iloc[0]}
        for r in grp.itertuples():
            for metric in METRICS:
                row[f"{r.scenario}: below PLL and AKF ({METRIC_TEXT[metric]})"] = getattr(r, f"{metric}_below_pll_and_akf")
        row["verdict"] = reading_verdict(list(grp["discriminator_below_pll_and_akf"]), list(grp["tracking_below_pll_and_akf"]))
        rows.append(row)
    return pd.DataFrame(rows)


def _g(v: float, fmt: str = ".3g") -> str:
    return "" if not np.isfinite(v) else format(v, fmt)


def readings_grid(long: pd.DataFrame, verdicts: pd.DataFrame) -> pd.DataFrame:
    by_label = dict(zip(verdicts["tracker"], verdicts["verdict"])) if len(verdicts) else {}
    rows = []
    for r in long.itertuples():
        row = {"scenario": r.scenario, "data": r.data, "tracker": r.label, "reading": r.reading_text, "trials": r.trials,
               "median T [rad^2/Hz]": _g(r.T_median), "median p": _g(r.p_median), "median w": _g(r.weight_median),
               "S_dphi,scint [rad^2/s]": _g(r.s_phi) if r.reading != "none" else "", "S_df,scint [Hz^2/s]": _g(r.s_f) if r.reading != "none" else "",
               "steady-state loop [Hz]": _g(r.bandwidth_hz, ".4g"), "weighted w K [Hz]": _g(r.bandwidth_weighted_hz, ".4g") if r.reading != "none" else ""}
        for metric in METRICS:
            name = METRIC_TEXT[metric]
            row[f"{name} [rad]"] = fmt_ci(getattr(r, f"{metric}_jitter_rad"), getattr(r, f"{metric}_ci95_lo"), getattr(r, f"{metric}_ci95_hi"))
            for key, ref in (("pll", "PLL"), ("akf", "AKF")):
                row[f"{name} minus {ref} [rad]"] = fmt_ci(getattr(r, f"{metric}_minus_{key}_rad"), getattr(r, f"{metric}_minus_{key}_ci95_lo"),
                                                         getattr(r, f"{metric}_minus_{key}_ci95_hi"))
            row[f"below PLL and AKF ({name})"] = getattr(r, f"{metric}_below_pll_and_akf")
        row["verdict (both scenarios)"] = by_label.get(r.label, "")
        rows.append(row)
    return pd.DataFrame(rows)


@table("susi_table_readings", ["table_readings", "table_readings_long", "table_readings_verdict"], paper=PAPER, section=SECTION,
       inputs=_inputs, surrogate=_surrogate)
def susi_table_readings(*results: xr.Dataset) -> dict:
    """The readings U1-U4 of eqs. (7)-(8): loop bandwidth, jitter with paired differences to the PLL and the AKF, verdict."""
    loops = next((r for r in results if is_loops(r)), None)
    results = [r for r in results if not is_loops(r)]
    long = readings_long(results, loops)
    verdicts = verdict_frame(long)
    note = ("Readings of eqs. (7)-(8) as pre-declared in docs/REPRODUCTION.md (scintrack.trackers.susi_kf.scintillation_q_psd gives each "
            "formula; T f^-p one-sided, rad^2/Hz, f_irr = 0.19 Hz). Loop: the noise bandwidth of the steady-state (Riccati) gain with the "
            "reading's scintillation PSDs at its own median on-line T, p (median over the steady-state time blocks of the per-block median "
            "over trials of T and mean over trials of p), R of eq. (10) at the scenario's C/N0; 'weighted' = the same for w K at the median "
            "eq. (12) weight w (a fixed-gain approximation). AKF: its clock-only loop. Criterion (pre-declared): in a scenario a reading "
            "holds on a metric when its SAKF minus the PLL and minus the AKF both have their paired 95% interval below 0; it explains the "
            "chapter when that holds on the discriminator jitter in both scenarios, explains part when it holds on the discriminator "
            "jitter in one scenario or only on the tracking-error jitter (in both scenarios), and otherwise does not explain it. "
            + _jitter_method(results[0]) + " " + _scenario_notes(results))
    title = f"Susi et al. 2014: the readings U1-U4 of eqs. (7)-(8) in the SAKF's process noise{_data_title(results)}"
    return {
        "table_readings": (readings_grid(long, verdicts), title, note),
        "table_readings_long": (long, title + ", long form", note),
        "table_readings_verdict": (verdicts, f"Susi et al. 2014: verdict of each reading of eqs. (7)-(8){_data_title(results)}", note),
    }
