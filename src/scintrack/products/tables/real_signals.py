"""The table of the real GPS recordings, with the synthetic SKYDEL-like segments beside them.

One row per satellite of interest of each recording, acquisition and tracking
side by side: the recordings the ``real_acquisition`` rule searched (the
registry's real captures, then the clean and jammed segments of the synthetic
IQ recording, all through the same reader, search and loops), and the
tracking summary where ``real_signals.tracked`` tracks the recording.

Rows of a recording: its detected satellites, the peaks marked as a stronger
satellite's cross-correlation, and for a synthetic segment every satellite it
was made with (detected or not: the jammed segment's satellites at 15 dB-Hz
stay in the table, not detected).  A recording without any such row shows its
strongest peak, not detected.  Numbers carry the digits each quantity has
(Doppler to 1 Hz, code phase, statistics and C/N0 to 0.1, fractions and phase
spreads to 0.01); a cell that does not apply is empty.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from ...pipeline import paths
from ..registry import REAL_PAPER, table

if TYPE_CHECKING:
    import xarray as xr

SECTION = "Real GPS L1 recordings"
#: how a row names the data of its recording
DATA_LABELS = {"real": "real", "synthetic SKYDEL-like": "synthetic SKYDEL-like"}


def table_inputs(config: Mapping[str, Any]) -> dict[str, str]:
    """Every recording's acquisition result, then the tracking result of every tracked recording."""
    out = {f"acquisition_{r}": paths.real_acquisition_path(r) for r in paths.signal_recordings(config)}
    out.update({f"tracking_{r}": paths.real_tracking_path(r) for r in config["real_signals"]["tracked"]})
    return out


def _num(value: float, digits: int) -> float | int | str:
    """``value`` rounded to ``digits`` decimals (an integer for 0), or "" when it is not a finite number."""
    value = float(value)
    if not math.isfinite(value):
        return ""
    return int(round(value)) if digits == 0 else round(value, digits)


def _search(acq: xr.Dataset) -> str:
    a = acq.attrs
    return f"{int(a['n_coherent_ms'])} ms x {int(a['n_blocks'])}, +-{float(a['doppler_span_hz']) / 1e3:g} kHz"


def _selected(acq: xr.Dataset) -> list[int]:
    """Indices of the rows of one recording (module docstring)."""
    detected = acq["detected"].values.astype(bool)
    keep = detected | (acq["cross_correlation_of"].values > 0)
    if "true_cn0_dbhz" in acq:
        keep |= np.isfinite(acq["true_cn0_dbhz"].values)
    if not keep.any():
        keep[int(np.argmax(acq["statistic"].values))] = True
    return [int(i) for i in np.flatnonzero(keep)]


def _acquisition_cell(acq: xr.Dataset, i: int, shown_alone: bool) -> str:
    if bool(acq["detected"].values[i]):
        return "detected"
    other = int(acq["cross_correlation_of"].values[i])
    if other:
        return f"cross-correlation of PRN {other}"
    return "not detected (strongest peak)" if shown_alone else "not detected"


def _tracking_cells(track: xr.Dataset | None, prn: int) -> dict[str, str]:
    names = ("tracked C/N0 [dB-Hz]", "lock fraction", "bit-edge fraction (transitions)", "PLL phase std [rad]", "MM phase std [rad]")
    if track is None or prn not in track["prn"].values.tolist():
        return dict.fromkeys(names, "")
    one = track.sel(prn=prn)
    edges = float(one["edge_fraction"])
    return dict(zip(names, (_num(one["mean_cn0_dbhz"], 1), _num(one["lock_fraction"], 2),
                            f"{edges:.2f} ({int(one['n_bit_edges'])})" if math.isfinite(edges) else "no sign change",
                            _num(one["pll_phase_error_std"], 2), _num(one["mm_phase_error_std"], 2))))


def signal_rows(acquisitions: list[xr.Dataset], tracks: Mapping[str, xr.Dataset]) -> pd.DataFrame:
    """The table's rows (module docstring), recordings in the order given."""
    rows = []
    for acq in acquisitions:
        name = str(acq.attrs["recording"])
        chosen = _selected(acq)
        alone = not (acq["detected"].values.astype(bool).any() or (acq["cross_correlation_of"].values > 0).any()
                     or ("true_cn0_dbhz" in acq and np.isfinite(acq["true_cn0_dbhz"].values).any()))
        for i in chosen:
            prn = int(acq["prn"].values[i])
            true = float(acq["true_cn0_dbhz"].values[i]) if "true_cn0_dbhz" in acq else math.nan
            rows.append({
                "data": DATA_LABELS[str(acq.attrs["data_kind"])], "recording": name, "search": _search(acq), "PRN": prn,
                "acquisition": _acquisition_cell(acq, i, alone),
                "Doppler [Hz]": _num(acq["doppler_hz"].values[i], 0),
                "code phase [chips]": _num(acq["code_phase_chips"].values[i], 1),
                "peak Lambda": _num(acq["statistic"].values[i], 1), "threshold gamma": _num(float(acq["threshold"]), 1),
                "acquisition C/N0 [dB-Hz]": _num(acq["cn0_dbhz"].values[i], 1),
                "true C/N0 [dB-Hz]": _num(true, 1),
                **_tracking_cells(tracks.get(name), prn),
            })
    return pd.DataFrame(rows)


def _jammed_note(acquisitions: list[xr.Dataset]) -> str:
    """What a recording with satellites but no detection expected: Lambda ~ K (1 + (C/N0) T) against gamma."""
    notes = []
    for acq in acquisitions:
        if "true_cn0_dbhz" not in acq or acq["detected"].values.astype(bool).any():
            continue
        true = acq["true_cn0_dbhz"].values
        if not np.isfinite(true).any():
            continue
        cn0 = float(np.nanmax(true))
        t = int(acq.attrs["n_coherent_ms"]) * 1e-3
        k = int(acq.attrs["n_blocks"])
        expected = k * (1.0 + 10 ** (cn0 / 10) * t)
        notes.append(f"{acq.attrs['recording']} acquires nothing, as expected: its satellites are at {cn0:.1f} dB-Hz, where "
                     f"{int(acq.attrs['n_coherent_ms'])} ms x {k} gives a mean peak of about K (1 + (C/N0) T) = {expected:.1f} against "
                     f"gamma = {float(acq['threshold']):.1f}; its rows stay in the table.")
    return " ".join(notes)


@table("real_table_signals", ["table_acquisition_tracking"], paper=REAL_PAPER, section=SECTION, inputs=table_inputs)
def real_table_signals(*results: xr.Dataset) -> dict:
    """Acquisition and tracking of every real recording and synthetic segment, one row per satellite of interest (module docstring)."""
    acquisitions = [r for r in results if "bin_statistic" in r]
    tracks = {str(r.attrs["recording"]): r for r in results if "bin_statistic" not in r}
    frame = signal_rows(acquisitions, tracks)
    tracked = ", ".join(tracks) or "none"
    note = ("Real captures and the synthetic SKYDEL-like clean and jammed segments through one chain: the same reader "
            "(scintrack.signals.recording), FFT search and threshold (scintrack.signals.gps.acquisition), loops and bit "
            "synchronisation (scintrack.experiments.real_tracking). Lambda is the normalised peak (noise units, Gamma(K, 1) "
            "per cell without signal); gamma the threshold for the stated false-alarm probability per search; the acquisition "
            "C/N0 is low by the Doppler and code straddle (up to 1.65 + 1.2 dB). Tracking columns (after the pull-in) for the "
            f"tracked recordings ({tracked}): mean M2M4 C/N0, lock fraction, fraction of the prompt sign changes on the bit-edge "
            "phase (data transitions seen), std of the Costas phase errors. Rows: detected satellites, cross-correlation peaks, "
            "every satellite of a synthetic segment, else the strongest peak. " + _jammed_note(acquisitions))
    return {"table_acquisition_tracking": (frame, "Real GPS recordings and the synthetic segments: acquisition and tracking", note)}
