"""Which config values each result depends on.

Every rule of the workflow gets, as ``params``, exactly the values its output
depends on, including those of its inputs (transitively), so that

* Snakemake's params trigger reruns a job when, and only when, one of them
  changes (``snakemake -n`` after a config edit lists exactly the affected jobs);
* the result records ``config_sha256 = hash_object(params)``
  (:func:`scintrack.io.provenance`), and :mod:`.consistency` can recompute
  the same hash from any config (the archived one, say) and refuse a result
  that was computed with other values.

The functions take the merged config and the wildcards of a result and return
plain JSON-able dicts.  Scripts read these params, never ``snakemake.config``.

Snakemake imports this module and calls these functions whenever it builds
the DAG, so they import only light modules (the ``*_spec`` halves of the
dataset modules, never numpy, xarray or numba); the tracking keys of
a tracker spec, which need the tracker modules, are remembered per code
version (:func:`_tracking_keys`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..codeversion import remembered
from ..data.surrogate_spec import surrogate_params
from ..data.synthetic_spec import csm_training_params
from ..settings import EXPERIMENT_KEYS, FLOORS_KEYS
from . import paths


def _sampling(config: Mapping[str, Any]) -> dict[str, Any]:
    return {"ts": float(config["sampling"]["ts"]), "nspa": int(config["sampling"]["nspa"]), "warmup_s": float(config["csm"]["warmup_s"])}


def tracker_specs(config: Mapping[str, Any], names) -> dict[str, Any]:
    return {name: dict(config["trackers"][name]) for name in names}


def tracker_types(config: Mapping[str, Any], names) -> list[str]:
    """The tracker types of the named trackers, sorted: what a rule runs, for the plug-in part of its code
    version (:func:`scintrack.jobcode.planned`; a code fact, not a config value, so not in the params)."""
    return sorted({str(config["trackers"][name]["type"]) for name in names})


def tracking_slice(config: Mapping[str, Any], names) -> dict[str, Any]:
    """The ``tracking`` keys that the scenario, the metrics (:data:`scintrack.settings.EXPERIMENT_KEYS`) and the named trackers read."""
    tracking = config["tracking"]
    keys = set(EXPERIMENT_KEYS)
    for name in names:
        keys.update(_tracking_keys(config["trackers"][name]))
    return {key: tracking[key] for key in sorted(keys) if key in tracking}


def _tracking_keys(spec: Mapping[str, Any]) -> list[str]:
    """:func:`scintrack.trackers.registry.tracking_keys` of a spec, remembered under the code version of
    the registry (:func:`scintrack.codeversion.remembered`): the registry imports every tracker module (numba)."""

    def compute() -> list[str]:
        from ..trackers.registry import tracking_keys

        return list(tracking_keys(spec))

    def keep() -> bool:
        from ..trackers.registry import from_package

        return from_package(spec["type"])

    return remembered("scintrack.trackers.registry", "tracking_keys", spec, compute, keep)


def training(config: Mapping[str, Any], s4: float | str) -> dict[str, Any]:
    return csm_training_params(config, float(s4))


def ar_fit(config: Mapping[str, Any], s4: float | str, phase: str = "unwrapped") -> dict[str, Any]:
    """AR fits of one training set; ``phase: wrapped`` fits the phase models on the wrapped phase (reading R5)."""
    out = {"ar_models": dict(config["ar_models"]), "training": training(config, s4)}
    if phase != "unwrapped":
        out["phase"] = phase
    return out


def ar_lut(config: Mapping[str, Any], phase: str = "unwrapped") -> dict[str, Any]:
    out = {"ar_models": dict(config["ar_models"]), "training": [training(config, s4) for s4 in config["ar_training"]["s4"]]}
    if phase != "unwrapped":
        out["phase"] = phase
    return out


def ar_diagnostics(config: Mapping[str, Any]) -> dict[str, Any]:
    vv = config["figures"]["vila_valls_2018"]
    cases = vv["ar_cases"]
    return {
        "cases": {k: dict(v) for k, v in cases.items()},
        "orders": list(vv["psd_orders"]),
        "nperseg": int(vv["welch_nperseg"]),
        "fits": {paths.fmt(c["s4"]): ar_fit(config, c["s4"]) for c in cases.values()},
    }


def experiment(config: Mapping[str, Any], name: str, scenario: str) -> dict[str, Any]:
    """Everything one (experiment, scenario) result depends on."""
    spec = config["experiments"][name]
    if scenario not in config["scenarios"]:
        raise KeyError(f"experiment {name}: scenario {scenario!r} is not defined under 'scenarios' in the config")
    trackers = list(spec["trackers"])
    sc = dict(config["scenarios"][scenario])
    out = {
        "experiment": name,
        "scenario_name": scenario,
        "scenario": sc,
        "tracker_names": trackers,
        "trackers": tracker_specs(config, trackers),
        "tracking": tracking_slice(config, trackers),
        "seed": int(config["seed"]),
        **_sampling(config),
        "n_trials": int(spec["trials"]),
        "shards": int(spec["shards"]),
        "lut": ar_lut(config, spec.get("lut", "unwrapped")),
    }
    if "ts" in sc:
        out["ts"] = float(sc["ts"])
    if "trace" in sc:
        out["trace"] = susi_trace(config, sc["trace"]["name"])
    return out


def susi_trace(config: Mapping[str, Any], name: str) -> dict[str, Any]:
    """What the trace of a trace scenario (Susi 2014) depends on."""
    from ..data.susi_traces import trace_input

    return trace_input(config, name)


def susi_indices(config: Mapping[str, Any], scenario: str) -> dict[str, Any]:
    """The S4 / Phi60 / Phi3 / T, p diagnostics of one Susi scenario (Figs. 3 and 6)."""
    su = config["susi_2014"]
    tracker = su["indices"]["tracker"]
    return {
        "experiment": experiment_like(config, scenario, [tracker]),
        "indices": dict(su["indices"]),
        "figure_trial": int(su["figure_trial"]),
    }


#: the real Septentrio index rows (both stations, GPS, elevation >= the mask) and the chosen event
SUSI_BISCEF_INDICES = f"{paths.SUSI_RESULTS}/biscef_indices.nc"


def susi_biscef(config: Mapping[str, Any]) -> dict[str, Any]:
    """The real BiScEF index rows and the event chosen from them: each file with its registry sha256, the
    elevation mask and the constellation (:mod:`scintrack.data.biscef`; the files are tracked, not configured)."""
    from ..data.biscef import ELEVATION_MIN_DEG, file_params
    from ..project import project_file

    return {"files": file_params(project_file(config["real_traces"]["registry"])), "elevation_min_deg": ELEVATION_MIN_DEG,
            "constellation": "GPS", "signal": "L1 C/A"}


def experiment_like(config: Mapping[str, Any], scenario: str, trackers) -> dict[str, Any]:
    """The params of an experiment of ``trackers`` on ``scenario`` (one trial)."""
    fake = {**config, "experiments": {"_": {"scenarios": [scenario], "trackers": list(trackers), "trials": 1, "shards": 1}}}
    out = experiment(fake, "_", scenario)
    for key in ("experiment", "n_trials", "shards", "lut"):
        out.pop(key)
    return out


def susi_scenarios(config: Mapping[str, Any]) -> list[str]:
    """The trace scenarios of the experiments (Susi 2014's) at the trace's own strength, in config order (the
    in-band sweep's copies with a ``trace.phase_scale`` other than 1 are the same event, not further scenarios)."""
    used = {sc for exp in config["experiments"].values() for sc in exp["scenarios"]}
    return [name for name, sc in config["scenarios"].items()
            if "trace" in sc and name in used and float(sc["trace"].get("phase_scale", 1.0)) == 1.0]


#: the jitter bound of the Susi chapter's scenarios (rule susi_jitter_bound, read by susi_table_jitter)
SUSI_JITTER_BOUND = f"{paths.SUSI_RESULTS}/jitter_bound.nc"


def susi_jitter_bound(config: Mapping[str, Any]) -> dict[str, Any]:
    """The jitter bound of each scenario of the Susi chapter run (``susi_chapter``): the scenario, its trace,
    Ts, seed and the ``tracking`` values that set its C/N0 and jitter windows; no tracker."""
    scenarios = config["experiments"].get("susi_chapter", {}).get("scenarios", [])
    out = {}
    for name in scenarios:
        sc = dict(config["scenarios"][name])
        out[name] = {"scenario": sc, "trace": susi_trace(config, sc["trace"]["name"]), "tracking": tracking_slice(config, []),
                     "ts": float(sc.get("ts", config["sampling"]["ts"]))}
    return {"scenarios": out, "seed": int(config["seed"])}


# --- Susi 2014: the AKF's steady-state loop bandwidth, decomposed (rule susi_akf_bandwidth) ---------------

#: the AKF trackers of the q_jerk sweep with their steady-state bandwidths (read by susi_table_akf_qjerk)
SUSI_AKF_QJERK_EXPERIMENT = "susi_akf_qjerk"
SUSI_AKF_BANDWIDTH = f"{paths.SUSI_RESULTS}/akf_qjerk_bandwidth.nc"


def susi_akf_bandwidth(config: Mapping[str, Any]) -> dict[str, Any]:
    """The steady-state loop bandwidth of every ``susi_akf`` tracker of the ``susi_akf_qjerk`` experiment on each of its
    scenarios: the tracker specs, each scenario's clock, C/N0 and Ts, and the ``tracking`` values the AKF reads."""
    spec = config["experiments"].get(SUSI_AKF_QJERK_EXPERIMENT, {})
    names = [t for t in spec.get("trackers", []) if config["trackers"][t]["type"] == "susi_akf"]
    scenarios = {name: {"scenario": dict(config["scenarios"][name]), "ts": float(config["scenarios"][name].get("ts", config["sampling"]["ts"]))}
                 for name in spec.get("scenarios", [])}
    return {"trackers": tracker_specs(config, names), "tracker_names": names, "scenarios": scenarios, "tracking": tracking_slice(config, names)}


# --- Susi 2014: the steady-state loops of the readings U1-U4 of eqs. (7)-(8) (rule susi_readings_loops) -----------

#: the experiment of the readings and the loop bandwidth of each reading at its median on-line T, p (read by susi_table_readings)
SUSI_READINGS_EXPERIMENT = "susi_readings"
SUSI_READINGS_LOOPS = f"{paths.SUSI_RESULTS}/readings_loops.nc"


def susi_readings_loops(config: Mapping[str, Any]) -> dict[str, Any]:
    """The Susi KF trackers (``susi_akf``, ``susi_sakf``) of the ``susi_readings`` experiment with their specs, and per
    scenario the scenario, Ts and the ``tracking`` values those trackers read (scintrack.experiments.susi_readings)."""
    spec = config["experiments"].get(SUSI_READINGS_EXPERIMENT, {})
    names = [t for t in spec.get("trackers", []) if config["trackers"][t]["type"] in ("susi_akf", "susi_sakf")]
    scenarios = {name: {"scenario": dict(config["scenarios"][name]), "tracking": tracking_slice(config, names),
                        "ts": float(config["scenarios"][name].get("ts", config["sampling"]["ts"]))} for name in spec.get("scenarios", [])}
    return {"experiment": SUSI_READINGS_EXPERIMENT, "trackers": tracker_specs(config, names), "scenarios": scenarios}


def floors(config: Mapping[str, Any], scenario: str) -> dict[str, Any]:
    """The achievability floors of one Table III cell: its (S4, tau0), the tracking values the
    filters use, the AR look-up table and the Monte Carlo settings."""
    sc = config["scenarios"][scenario]
    (seg,) = sc["segments"]
    keys = FLOORS_KEYS
    return {
        "scenario": scenario, "s4": float(seg["s4"]), "tau0": float(seg["tau0"]),
        "tracking": {k: config["tracking"][k] for k in keys}, "seed": int(config["seed"]), **_sampling(config),
        "floors": {k: v for k, v in config["floors"].items() if k != "scenarios"}, "lut": ar_lut(config),
    }


def shard_trials(config: Mapping[str, Any], name: str, shard: int) -> list[int]:
    """The trial indices of block ``shard`` of experiment ``name`` (:func:`scintrack.batching.trial_blocks`)."""
    from ..batching import trial_blocks

    spec = config["experiments"][name]
    return trial_blocks(int(spec["trials"]), int(spec["shards"]))[shard]


# --- Sec. VI-E: real traces or the surrogate -------------------------------------


def trace_input(config: Mapping[str, Any], event: str) -> dict[str, Any]:
    """What defines the canonical trace file of an event."""
    rt = config["real_traces"]
    if paths.trace_source(config) == "real":
        return {"source": dict(rt["sources"][event]), "bands": list(rt["bands"]), "ts": float(config["sampling"]["ts"])}
    return {"surrogate": surrogate_params(config, event)}


def trace_models(config: Mapping[str, Any], event: str) -> dict[str, Any]:
    rt = config["real_traces"]
    return {"trace": trace_input(config, event), "fit_s": float(rt["fit_s"]), "ts": float(config["sampling"]["ts"])}


def trace_diagnostics(config: Mapping[str, Any]) -> dict[str, Any]:
    rt = config["real_traces"]
    return {
        "traces": {e: trace_input(config, e) for e in rt["events"]},
        "ts": float(config["sampling"]["ts"]),
        "window_s": float(rt["s4_window_s"]),
        "pacf_lags": int(config["figures"]["vila_valls_2018"]["pacf_lags_shown"]),
        "segment_s": float(rt["pacf_segment_s"]),
    }


def _trace_experiment(config: Mapping[str, Any], event: str, names) -> dict[str, Any]:
    rt = config["real_traces"]
    return {
        "models": trace_models(config, event),
        "tracker_names": list(names),
        "trackers": tracker_specs(config, names),
        "tracking": tracking_slice(config, names),
        "seed": int(config["seed"]),
        "ts": float(config["sampling"]["ts"]),
        "fit_s": float(rt["fit_s"]),
        "eval_s": float(rt["eval_s"]),
        "trials": int(rt["trials"]),
    }


def trace_static(config: Mapping[str, Any], event: str) -> dict[str, Any]:
    return _trace_experiment(config, event, [config["real_traces"]["static_tracker"]])


def trace_dynamics(config: Mapping[str, Any], event: str) -> dict[str, Any]:
    rt = config["real_traces"]
    return {**_trace_experiment(config, event, rt["trackers"]), "rmse_start_s": float(rt["rmse_start_s"]), "lut": ar_lut(config)}


# --- Zhao et al.: jammed GPS L1 C/A -------------------------------------------------


def gps_dataset(config: Mapping[str, Any]) -> dict[str, Any]:
    from ..data.gps_jamming_spec import gps_jamming_params

    return gps_jamming_params(config)


def gps_iq(config: Mapping[str, Any]) -> dict[str, Any]:
    from ..data.gps_iq import iq_params

    return iq_params(config)


def zhao_cn0(config: Mapping[str, Any]) -> dict[str, Any]:
    g = config["gps_jamming"]
    return {"dataset": gps_dataset(config), "seed": int(config["seed"]), **dict(g["cn0_estimate"])}


def zhao_spectrum(config: Mapping[str, Any]) -> dict[str, Any]:
    return {"iq": gps_iq(config), "welch_nperseg": int(config["gps_jamming"]["welch_nperseg"])}


def zhao_bit_prediction(config: Mapping[str, Any]) -> dict[str, Any]:
    """The bit prediction depends on the dataset (its timing and satellites) and the navigation file only."""
    return {"dataset": gps_dataset(config)}


def _zhao(config: Mapping[str, Any], leave_out: tuple[str, ...]) -> dict[str, Any]:
    rc = {k: v for k, v in config["zhao_receiver"].items() if k not in ("trial_batch", *leave_out)}
    return {
        "dataset": gps_dataset(config),
        "seed": int(config["seed"]),
        "receiver": rc,
        "trackers": tracker_specs(config, [rc["pll"], rc["mm"]]),  # never left out
    }


def zhao_receiver(config: Mapping[str, Any]) -> dict[str, Any]:
    """The receiver experiment (channels and positions): the dataset, the receiver settings and the specs of its two trackers.

    ``trial_batch`` is left out: it bounds a job's memory and no result depends on it
    (``tests/test_gps_receiver.py``), so the rules pass it as a resource and changing it reruns nothing.
    ``cn0_sweep`` is left out too: only the sweep points read it (:func:`zhao_sweep`).
    """
    return _zhao(config, ("cn0_sweep",))


def zhao_sweep(config: Mapping[str, Any]) -> dict[str, Any]:
    """One point of the jammed-C/N0 sweep: :func:`zhao_receiver` with ``cn0_sweep.trials`` and without ``trials``
    (a sweep point runs ``cn0_sweep.trials`` trials; ``receiver.trials`` is the channels' count).

    The list of sweep points (``cn0_sweep.cn0_dbhz``) is not a value of any one point (its C/N0 is its
    wildcard): adding a point runs that point only."""
    out = _zhao(config, ("trials",))
    out["receiver"]["cn0_sweep"] = {"trials": int(config["zhao_receiver"]["cn0_sweep"]["trials"])}
    return out


# --- Zhao et al.: the pre-declared readings of the position spread (docs/REPRODUCTION.md) ---


def zhao_clean_dataset(config: Mapping[str, Any]) -> dict[str, Any]:
    """The clean scenario's dataset: ``gps_jamming`` with the jammer off for the whole scenario."""
    from ..experiments.zhao_readings import clean_scenario_config

    return gps_dataset(clean_scenario_config(config))


def zhao_reading(config: Mapping[str, Any], reading: str) -> dict[str, Any]:
    """One reading's channels and receiver: :func:`zhao_receiver` with the reading's receiver (its overrides,
    ``zhao_readings.trials`` and ``variants``), on its scenario's dataset; with ``code_phase: sample`` also the
    recording's sampling rate (``gps_jamming.iq.sample_rate_hz``), the grid the code phase is read on."""
    from ..experiments.zhao_readings import reading_receiver, reading_spec

    rc = reading_receiver(config, reading)
    clean = reading_spec(config, reading)["scenario"] == "clean"
    out = {
        "dataset": zhao_clean_dataset(config) if clean else gps_dataset(config),
        "seed": int(config["seed"]),
        "receiver": rc,
        "trackers": tracker_specs(config, [rc["pll"], rc["mm"]]),
    }
    if rc.get("code_phase", "continuous") == "sample":
        out["sample_rate_hz"] = float(config["gps_jamming"]["iq"]["sample_rate_hz"])
    return out


def zhao_reading_receiver(config: Mapping[str, Any], reading: str) -> dict[str, Any]:
    """One reading's positions: :func:`zhao_reading` and the reading's name, scenario and ``jammed_from``
    (written into the result's attributes, which the readings table pairs by)."""
    from ..experiments.zhao_readings import reading_spec

    spec = reading_spec(config, reading)
    return {**zhao_reading(config, reading), "reading": reading, "scenario": spec["scenario"], "jammed_from": spec["jammed_from"] or ""}


# --- Real GPS recordings (docs/real-signals.md) ----------------------------------------


def real_acquisition(config: Mapping[str, Any], recording: str) -> dict[str, Any]:
    """One recording's acquisition: ``real_signals.acquisition`` updated by the recording's own settings
    (``real_signals.recordings.<name>``, or ``real_signals.synthetic`` for a synthetic segment), and for a
    synthetic segment the params of the IQ recording it reads.  A real capture is identified by its name;
    its bytes are checked against its sidecar's sha256 when read."""
    rs = config["real_signals"]
    synthetic = recording in paths.SYNTHETIC_SEGMENTS
    own = rs["synthetic"] if synthetic else rs["recordings"].get(recording) or {}
    out: dict[str, Any] = {"recording": recording, "acquisition": {**dict(rs["acquisition"]), **dict(own)}}
    if synthetic:
        out["iq"] = gps_iq(config)
    return out


def real_tracking(config: Mapping[str, Any], recording: str) -> dict[str, Any]:
    """Tracking of one recording: its acquisition's params and ``real_signals.tracking`` (the loop settings).
    The list of tracked recordings (``real_signals.tracked``) is not a value of any one result."""
    return {**real_acquisition(config, recording), "tracking": dict(config["real_signals"]["tracking"])}


def results(config: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """Every result file of the default run -> the params it depends on."""
    out: dict[str, dict[str, Any]] = {paths.AR_LUT: ar_lut(config), paths.VV_DIAGNOSTICS: ar_diagnostics(config)}
    if any(spec.get("lut") == "wrapped" for spec in config["experiments"].values()):
        out[paths.AR_LUT_WRAPPED] = ar_lut(config, "wrapped")
    for name, spec in config["experiments"].items():
        for scenario in spec["scenarios"]:
            out[paths.exp_result(name, scenario)] = experiment(config, name, scenario)
    out[paths.trace_diagnostics_path(config)] = trace_diagnostics(config)
    for event in config["real_traces"]["events"]:
        out[paths.trace_models_path(config, event)] = trace_models(config, event)
        out[paths.trace_static_path(config, event)] = trace_static(config, event)
        out[paths.trace_dynamics_path(config, event)] = trace_dynamics(config, event)
    for scenario in config["floors"]["scenarios"]:
        out[paths.floors_path(scenario)] = floors(config, scenario)
    for scenario in susi_scenarios(config):
        out[paths.susi_indices_path(scenario)] = susi_indices(config, scenario)
    out[SUSI_BISCEF_INDICES] = susi_biscef(config)
    out[SUSI_JITTER_BOUND] = susi_jitter_bound(config)
    if SUSI_AKF_QJERK_EXPERIMENT in config["experiments"]:
        out[SUSI_AKF_BANDWIDTH] = susi_akf_bandwidth(config)
    if SUSI_READINGS_EXPERIMENT in config["experiments"]:  # the Susi readings U1-U4
        out[SUSI_READINGS_LOOPS] = susi_readings_loops(config)
    out[paths.ZHAO_CN0] = zhao_cn0(config)
    out[paths.ZHAO_SPECTRUM] = zhao_spectrum(config)
    out[paths.ZHAO_BIT_PREDICTION] = zhao_bit_prediction(config)
    for prn in config["gps_jamming"]["prns"]:
        out[paths.zhao_channel(prn)] = zhao_receiver(config)
    out[paths.ZHAO_RECEIVER] = zhao_receiver(config)
    for cn0 in config["zhao_receiver"]["cn0_sweep"]["cn0_dbhz"]:
        out[paths.zhao_sweep_point(cn0)] = zhao_sweep(config)
    for reading in config["zhao_readings"]["readings"]:  # the pre-declared readings of the position spread
        for prn in config["gps_jamming"]["prns"]:
            out[paths.zhao_reading_channel(reading, prn)] = zhao_reading(config, reading)
        out[paths.zhao_reading_receiver(reading)] = zhao_reading_receiver(config, reading)
    for recording in paths.signal_recordings(config):
        out[paths.real_acquisition_path(recording)] = real_acquisition(config, recording)
    for recording in config["real_signals"]["tracked"]:
        out[paths.real_tracking_path(recording)] = real_tracking(config, recording)
    return dict(sorted(out.items()))
