# Real GPS L1 recordings (every entry of the dataset registry with a sidecar,
# data/real/) and the synthetic SKYDEL-like clean and jammed segments of
# gps_iq_recording through one chain: reader, acquisition, tracking
# (docs/real-signals.md).  `snakemake --cores 2 real_signals` builds the
# results, the figures and the table.

import re

from scintrack.pipeline import real_signals as real_signals_check

RS = config["real_signals"]
try:  # names that exist, files on disk, lengths that fit: one `error:` line naming the key or file
    SIGNAL_RECORDINGS = paths.signal_recordings(config)
    real_signals_check.check(config, SOURCE)
except ConfigError as exc:
    fail(locate(str(exc), _config_layers()))
except InputError as exc:
    fail(exc)
RECORDING_PATTERN = "|".join(map(re.escape, SIGNAL_RECORDINGS))


rule real_acquisition:
    """Acquisition of one recording (real capture or synthetic segment): every PRN's peak, threshold, C/N0 and per-Doppler statistic."""
    input:
        unpack(lambda w: real_signals_check.recording_files(config, w.recording)),
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
        unpack(lambda w: real_signals_check.recording_files(config, w.recording)),
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
