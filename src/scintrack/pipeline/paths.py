"""Where every dataset and result of the pipeline lives, as a function of the config.

The Snakemake rules (``workflow/rules/common.smk``) and the archive/verify
code both ask this module, so a path convention exists once.  The dataset
modules (generators) are imported only where a dataset path needs its
version, so figure and table jobs that import this module stay light.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

AR_LUT = "results/ar_models/ar_lut.nc"
AR_LUT_WRAPPED = "results/ar_models/wrapped/ar_lut.nc"  # phase AR models fitted on the wrapped phase (reading R5)
VV_DIAGNOSTICS = "results/vila_valls_2018/ar_diagnostics.nc"


def floors_path(scenario: str) -> str:
    """The achievability floors of one Table III cell (``scenario`` may be a wildcard)."""
    return f"results/vila_valls_2018/floors/{scenario}.nc"
DATASET_MANIFEST = "data/manifest.json"


def fmt(x: float) -> str:
    """Canonical text of a grid value in file names (0.9, not 0.90)."""
    return f"{float(x):g}"


def training_path(config: Mapping[str, Any], s4: float | str) -> str:
    from ..data.synthetic_spec import csm_training_name, csm_training_params, csm_training_version

    params = csm_training_params(config, float(s4))
    return f"data/synthetic/{csm_training_name(float(s4))}/{csm_training_version(params)}.nc"


def ar_fit_path(s4: float | str, phase: str = "unwrapped") -> str:
    return f"results/ar_models/{'' if phase == 'unwrapped' else phase + '/'}fits/s4-{fmt(s4)}.nc"


def lut_path(phase: str = "unwrapped") -> str:
    return AR_LUT if phase == "unwrapped" else AR_LUT_WRAPPED


def exp_result(experiment: str, scenario: str) -> str:
    return f"results/experiments/{experiment}/{scenario}.nc"


def trace_source(config: Mapping[str, Any]) -> str:
    """"real" when real traces are configured, else "surrogate"."""
    return "real" if config["real_traces"]["sources"] else "surrogate"


def raw_trace_path(config: Mapping[str, Any], event: str) -> str:
    src = config["real_traces"]["sources"][event]
    fmt_ = src.get("format") or Path(str(src.get("url") or src.get("path")).split("?")[0]).suffix.lstrip(".").lower()
    if fmt_ not in ("nc", "mat", "npz", "csv"):
        raise ValueError(f"real_traces.sources.{event}: cannot tell the format from {src}; add format: nc|mat|npz|csv")
    return f"data/raw/jrc_hanoi/{event}.{fmt_}"


def trace_path(config: Mapping[str, Any], event: str) -> str:
    """The canonical (validated) trace file of an event, real or surrogate."""
    if trace_source(config) == "real":
        return f"data/traces/real/{event}.nc"
    from ..data.surrogate_spec import surrogate_params, surrogate_version

    params = surrogate_params(config, event)
    return f"data/synthetic/surrogate_{event}/{surrogate_version(params)}.nc"


def trace_results(config: Mapping[str, Any]) -> str:
    return f"results/real_traces/{trace_source(config)}"


def trace_models_path(config: Mapping[str, Any], event: str) -> str:
    return f"{trace_results(config)}/ar_models/{event}.nc"


def trace_diagnostics_path(config: Mapping[str, Any]) -> str:
    return f"{trace_results(config)}/diagnostics.nc"


def trace_static_path(config: Mapping[str, Any], event: str) -> str:
    return f"{trace_results(config)}/static/{event}.nc"


def trace_dynamics_path(config: Mapping[str, Any], event: str) -> str:
    return f"{trace_results(config)}/dynamics/{event}.nc"


# --- Susi et al. 2014 ----------------------------------------------------------------

SUSI_RESULTS = "results/susi_2014"


def susi_indices_path(scenario: str) -> str:
    """S4 / Phi60 / Phi3 / T, p diagnostics of one Susi scenario (``scenario`` may be a wildcard)."""
    return f"{SUSI_RESULTS}/indices/{scenario}.nc"


def scenario_trace_path(config: Mapping[str, Any], scenario: str) -> str | None:
    """The trace file a trace scenario reads, else None."""
    sc = config["scenarios"][scenario]
    if "trace" not in sc:
        return None
    from ..data.susi_traces import trace_file

    return trace_file(config, sc["trace"]["name"])


# --- Zhao et al.: the jammed GPS L1 C/A dataset and its results ------------------

ZHAO_RESULTS = "results/zhao_jamming"
ZHAO_CN0 = f"{ZHAO_RESULTS}/cn0_estimates.nc"
ZHAO_SPECTRUM = f"{ZHAO_RESULTS}/iq_spectrum.nc"
ZHAO_RECEIVER = f"{ZHAO_RESULTS}/receiver.nc"
ZHAO_BIT_PREDICTION = f"{ZHAO_RESULTS}/bit_prediction.nc"  # the upload-robust prediction of every satellite (rule zhao_bit_prediction)


def zhao_sweep_point(cn0: float | str) -> str:
    """One point of the jammed-C/N0 sweep (``cn0`` may be the wildcard ``"{cn0}"``)."""
    return f"{ZHAO_RESULTS}/cn0_sweep/cn0-{cn0 if isinstance(cn0, str) else fmt(cn0)}.nc"


def zhao_channel(prn: int | str) -> str:
    """One satellite channel's result (``prn`` may be the wildcard ``"{prn}"``)."""
    return f"{ZHAO_RESULTS}/channels/prn{prn}.nc"


# Zhao et al.: the pre-declared readings of the position spread (docs/REPRODUCTION.md)
ZHAO_READINGS = f"{ZHAO_RESULTS}/readings"


def zhao_reading_channel(reading: str, prn: int | str) -> str:
    """One channel of one reading (``reading``/``prn`` may be wildcards)."""
    return f"{ZHAO_READINGS}/{reading}/channels/prn{prn}.nc"


def zhao_reading_receiver(reading: str) -> str:
    """Positions and ENU statistics of one reading."""
    return f"{ZHAO_READINGS}/{reading}/receiver.nc"


def gps_clean_dataset_path(config: Mapping[str, Any]) -> str:
    """The clean scenario's dataset (the jammer off for the whole scenario): another version of the same dataset."""
    from ..experiments.zhao_readings import clean_scenario_config

    return gps_dataset_path(clean_scenario_config(config))


def gps_dataset_path(config: Mapping[str, Any]) -> str:
    from ..data.gps_jamming_spec import NAME, gps_jamming_params, gps_jamming_version

    return f"data/synthetic/{NAME}/{gps_jamming_version(gps_jamming_params(config))}.nc"


IQ_SEGMENTS = ("clean", "jammed")


def gps_iq_paths(config: Mapping[str, Any]) -> dict[str, str]:
    """The IQ recordings (int16 interleaved I/Q) of the clean and jammed segments and their JSON sidecars."""
    from ..data.gps_iq import NAME, iq_params, iq_version

    folder = f"data/synthetic/{NAME}/{iq_version(iq_params(config))}"
    out = {}
    for seg in IQ_SEGMENTS:
        out[f"{seg}_data"] = f"{folder}/{seg}.bin"
        out[f"{seg}_sidecar"] = f"{folder}/{seg}.bin.json"
    return out


# --- Real GPS recordings and the synthetic segments through the same chain ---------

REAL_SIGNALS_RESULTS = "results/real_signals"
#: recording name -> segment of the SKYDEL-like IQ recording (rule gps_iq_recording) that the real-signal chain also runs on
SYNTHETIC_SEGMENTS = {"synthetic_clean": "clean", "synthetic_jammed": "jammed"}


def real_recordings(config: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """The raw-sample recordings of the dataset registry (``real_traces.registry``): the entries with a ``sidecar``,
    name -> entry (``path``, ``sidecar``, ``sha256``, relative to the project)."""
    from ..data.registry import read_registry
    from ..project import project_file

    datasets = read_registry(project_file(config["real_traces"]["registry"]))["datasets"]
    return {name: dict(entry) for name, entry in datasets.items() if isinstance(entry, dict) and "sidecar" in entry}


def signal_recordings(config: Mapping[str, Any]) -> list[str]:
    """Every recording the real-signal acquisition runs on: the registry's real recordings, then the synthetic segments."""
    return [*real_recordings(config), *SYNTHETIC_SEGMENTS]


def signal_recording_files(config: Mapping[str, Any], recording: str) -> dict[str, str]:
    """``data`` and ``sidecar`` of a recording: the registry's paths (project-relative) or the gps_iq_recording outputs."""
    if recording in SYNTHETIC_SEGMENTS:
        iq = gps_iq_paths(config)
        return {"data": iq[f"{SYNTHETIC_SEGMENTS[recording]}_data"], "sidecar": iq[f"{SYNTHETIC_SEGMENTS[recording]}_sidecar"]}
    entry = real_recordings(config)[recording]
    return {"data": str(entry["path"]), "sidecar": str(entry["sidecar"])}


def real_acquisition_path(recording: str) -> str:
    """The acquisition result of one recording (``recording`` may be the wildcard ``"{recording}"``)."""
    return f"{REAL_SIGNALS_RESULTS}/acquisition/{recording}.nc"


def real_tracking_path(recording: str) -> str:
    """The tracking result of one recording (``recording`` may be the wildcard ``"{recording}"``)."""
    return f"{REAL_SIGNALS_RESULTS}/tracking/{recording}.nc"
