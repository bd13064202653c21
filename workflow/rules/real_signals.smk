# Real GPS L1 recordings (every entry of the dataset registry with a sidecar,
# data/real/) and the synthetic SKYDEL-like clean and jammed segments of
# gps_iq_recording through one chain: reader, acquisition, tracking
# (docs/real-signals.md).  `snakemake --cores 2 real_signals` builds the
# results, the figures and the table.

import json
import re

RS = config["real_signals"]
try:  # the registry names the real recordings; a broken registry is one line here
    REAL_RECORDINGS = paths.real_recordings(config)
except InputError as exc:
    fail(exc)
SIGNAL_RECORDINGS = [*REAL_RECORDINGS, *paths.SYNTHETIC_SEGMENTS]  # = paths.signal_recordings(config)


def _recording_length_ms(name):
    """Length of a recording from its sidecar (real) or the config (synthetic segment), without reading samples."""
    if name in paths.SYNTHETIC_SEGMENTS:
        return 1e3 * float(config["gps_jamming"]["iq"]["length_s"])
    side = Path(repo_path(REAL_RECORDINGS[name]["sidecar"]))
    try:
        meta = json.loads(side.read_text(encoding="utf-8"))
        return 1e3 * int(meta["n_samples"]) / float(meta["sample_rate_hz"])
    except (OSError, ValueError, KeyError, TypeError, ZeroDivisionError) as exc:
        fail(f"{side}: cannot read n_samples and sample_rate_hz ({one_line(exc)}); restore the sidecar (git checkout data/real) or fix it (docs/real-signals.md)")


def _bad_value(message):
    """Stop with one `error:` line naming the key and the config layer that sets it."""
    fail(locate(message, _config_layers()))


def _check_real_signals():
    """What the schema cannot say: names that exist, lengths that fit (one `error:` line naming the key)."""
    where = SOURCE
    for name, entry in REAL_RECORDINGS.items():
        for key in ("path", "sidecar"):
            if not Path(repo_path(entry[key])).is_file():
                fail(f"real recording {name}: {entry[key]} not found; restore it (git checkout data/real) or remove its entry from {REGISTRY}")
    for name in RS["recordings"]:
        if name not in REAL_RECORDINGS:
            _bad_value(f"invalid config value at 'real_signals.recordings.{name}': not a recording of the registry {config['real_traces']['registry']} "
                       f"(known: {', '.join(REAL_RECORDINGS)}); fix it in {where}")
    for name in SIGNAL_RECORDINGS:
        acq = P.real_acquisition(config, name)["acquisition"]
        need, length = int(acq["n_coherent_ms"]) * int(acq["n_blocks"]), _recording_length_ms(name)
        if need > length + 1e-9:
            key = "real_signals.synthetic" if name in paths.SYNTHETIC_SEGMENTS else f"real_signals.recordings.{name}"
            _bad_value(f"invalid config value at '{key}': n_coherent_ms x n_blocks = {acq['n_coherent_ms']} x {acq['n_blocks']} ms "
                       f"does not fit in the {length:g}-ms recording {name}; set a shorter block or fewer blocks in {where}")
    tr = RS["tracking"]
    if tr["pull_in_ms"] < tr["mm_m2m4_window"]:
        _bad_value(f"invalid config value at 'real_signals.tracking.pull_in_ms': {tr['pull_in_ms']} ms must cover mm_m2m4_window "
                   f"({tr['mm_m2m4_window']} epochs of 1 ms): the MM filter's noise prior comes from the pull-in; fix it in {where}")
    for name in RS["tracked"]:
        if name not in SIGNAL_RECORDINGS:
            _bad_value(f"invalid config value at 'real_signals.tracked': {name!r} is not a recording (known: {', '.join(SIGNAL_RECORDINGS)}); fix it in {where}")
        need, length = max(tr["pull_in_ms"] + 20, tr["fine_search_ms"]) + 2, _recording_length_ms(name)
        if length < need:
            _bad_value(f"invalid config value at 'real_signals.tracked': {name} lasts {length:g} ms, less than the {need} ms tracking needs "
                       f"(real_signals.tracking.pull_in_ms + one 20-ms data bit, and fine_search_ms); remove it or shorten those settings in {where}")


_check_real_signals()
RECORDING_PATTERN = "|".join(map(re.escape, SIGNAL_RECORDINGS))


def recording_files(wildcards):
    """The data file and sidecar of a recording: the repository's copy of a real one, gps_iq_recording's output for a segment."""
    files = paths.signal_recording_files(config, wildcards.recording)
    if wildcards.recording in paths.SYNTHETIC_SEGMENTS:
        return files
    return {k: repo_path(v) for k, v in files.items()}


rule real_acquisition:
    """Acquisition of one recording (real capture or synthetic segment): every PRN's peak, threshold, C/N0 and per-Doppler statistic."""
    input:
        unpack(recording_files),
    output:
        ensure(paths.real_acquisition_path("{recording}"), non_empty=True),
    params:
        acquisition=lambda w: P.real_acquisition(config, w.recording),
        code=code("real_acquisition.py"),
    wildcard_constraints:
        recording=RECORDING_PATTERN,
    log:
        "logs/real_signals/acquisition_{recording}.log",
    benchmark:
        "results/benchmarks/real_signals/acquisition_{recording}.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("real_acquisition"),
        runtime=RES.runtime("real_acquisition"),
    script:
        "../scripts/real_acquisition.py"


rule real_tracking:
    """Costas PLL and MM channel with a DLL on every satellite a recording's acquisition detected: prompts, phase errors, C/N0, lock, bit edges."""
    input:
        unpack(recording_files),
        acquisition=paths.real_acquisition_path("{recording}"),
    output:
        ensure(paths.real_tracking_path("{recording}"), non_empty=True),
    params:
        tracking=lambda w: P.real_tracking(config, w.recording),
        code=code("real_tracking.py"),
    wildcard_constraints:
        recording=RECORDING_PATTERN,
    log:
        "logs/real_signals/tracking_{recording}.log",
    benchmark:
        "results/benchmarks/real_signals/tracking_{recording}.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("real_tracking"),
        runtime=RES.runtime("real_tracking"),
    script:
        "../scripts/real_tracking.py"


rule real_signals:
    """Every real-signal result, figure and table: `snakemake --cores 2 real_signals`."""
    input:
        [paths.real_acquisition_path(r) for r in SIGNAL_RECORDINGS],
        [paths.real_tracking_path(r) for r in RS["tracked"]],
        [f for p in [*FIGURES.values(), *TABLES.values()] if p.paper == "real_signals" for f in p.outputs(config).values()],
