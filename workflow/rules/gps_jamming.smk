# Zhao, Khanafseh & Pervan: the jammed SKYDEL-like GPS L1 C/A dataset (truth
# per satellite and code epoch, versioned like every synthetic dataset), its
# IQ recording, and the results behind the dataset's figures.

GJ = config["gps_jamming"]
EPHEMERIDES = repo_path(GJ["ephemerides"])
if not Path(EPHEMERIDES).is_file():  # an input from outside the pipeline: say so in one line, not as a missing-input report
    fail(f"gps_jamming.ephemerides: RINEX navigation file {GJ['ephemerides']} not found; restore it (git checkout data/ephemerides) "
         "or point the setting at an existing file")
GPS_DATASET = paths.gps_dataset_path(config)
GPS_IQ = paths.gps_iq_paths(config)


rule gps_jamming_dataset:
    """Truth of the jammed GPS scenario: geometry from real ephemerides, clock, LNAV message, C/N0 profile."""
    input:
        ephemerides=EPHEMERIDES,
    output:
        ensure(GPS_DATASET, non_empty=True),
    params:
        dataset=P.gps_dataset(config),
        code=code("make_gps_jamming.py"),
    log:
        "logs/data/gps_jamming.log",
    benchmark:
        "results/benchmarks/gps_jamming_dataset.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("gps_jamming_dataset"),
        runtime=RES.runtime("gps_jamming_dataset"),
    script:
        "../scripts/make_gps_jamming.py"


rule gps_iq_recording:
    """SKYDEL-like complex baseband recording (int16 I/Q) of a clean and a jammed segment, with a JSON sidecar."""
    input:
        dataset=GPS_DATASET,
    output:
        **{k: ensure(v, non_empty=True) for k, v in GPS_IQ.items()},
    params:
        iq=P.gps_iq(config),
        code=code("make_gps_iq.py"),
    log:
        "logs/data/gps_iq.log",
    benchmark:
        "results/benchmarks/gps_iq_recording.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("gps_iq_recording"),
        runtime=RES.runtime("gps_iq_recording"),
    script:
        "../scripts/make_gps_iq.py"


rule zhao_cn0_estimates:
    """C/N0 over the scenario estimated from correlator outputs (M2M4), beside the truth (Figs. 5 and 8)."""
    input:
        dataset=GPS_DATASET,
    output:
        ensure(paths.ZHAO_CN0, non_empty=True),
    params:
        cn0=P.zhao_cn0(config),
        code=code("zhao_cn0.py"),
    log:
        "logs/zhao_jamming/cn0_estimates.log",
    threads: 1
    resources:
        mem_mb=RES.mem_mb("zhao_cn0_estimates"),
        runtime=RES.runtime("zhao_cn0_estimates"),
    script:
        "../scripts/zhao_cn0.py"


rule zhao_iq_spectrum:
    """Welch spectra of the clean and jammed segments of the IQ recording (Figs. 5 and 8)."""
    input:
        **GPS_IQ,
        dataset=GPS_DATASET,
    output:
        ensure(paths.ZHAO_SPECTRUM, non_empty=True),
    params:
        spectrum=P.zhao_spectrum(config),
        code=code("zhao_iq_spectrum.py"),
    log:
        "logs/zhao_jamming/iq_spectrum.log",
    threads: 1
    resources:
        mem_mb=RES.mem_mb("zhao_iq_spectrum"),
        runtime=RES.runtime("zhao_iq_spectrum"),
    script:
        "../scripts/zhao_iq_spectrum.py"


# --- the receiver: Costas PLL, MM Kalman filter with bit prediction, DLL, positioning


rule zhao_bit_prediction:
    """The upload-robust bit prediction of every satellite over the scenario (read by every channel and sweep point)."""
    input:
        dataset=GPS_DATASET,
        ephemerides=EPHEMERIDES,
    output:
        ensure(paths.ZHAO_BIT_PREDICTION, non_empty=True),
    params:
        prediction=P.zhao_bit_prediction(config),
        code=code("zhao_bit_prediction.py"),
    log:
        "logs/zhao_jamming/bit_prediction.log",
    threads: 1
    resources:
        mem_mb=RES.mem_mb("zhao_bit_prediction"),
        runtime=RES.runtime("zhao_bit_prediction"),
    script:
        "../scripts/zhao_bit_prediction.py"


rule zhao_channel:
    """One satellite channel over all Monte Carlo trials: PLL, MM filter per bit-prior strategy, DLL."""
    input:
        dataset=GPS_DATASET,
        ephemerides=EPHEMERIDES,
        prediction=paths.ZHAO_BIT_PREDICTION,
    output:
        ensure(paths.zhao_channel("{prn}"), non_empty=True),
    params:
        receiver=P.zhao_receiver(config),
        code=code("zhao_channel.py"),
    log:
        "logs/zhao_jamming/channel_prn{prn}.log",
    benchmark:
        "results/benchmarks/zhao_channel/prn{prn}.tsv"
    threads: 1
    resources:
        mem_mb=RES.zhao_channel_mem_mb(config),
        runtime=RES.zhao_channel_runtime(config),
        trial_batch=int(config["zhao_receiver"]["trial_batch"]),  # memory only: not a param (no result depends on it)
    script:
        "../scripts/zhao_channel.py"


rule zhao_receiver:
    """Positions at 1 Hz from the channels' pseudoranges, ENU errors, and the per-variant metrics."""
    input:
        dataset=GPS_DATASET,
        channels=[paths.zhao_channel(p) for p in GJ["prns"]],
    output:
        ensure(paths.ZHAO_RECEIVER, non_empty=True),
    params:
        receiver=P.zhao_receiver(config),
        code=code("zhao_receiver.py"),
    log:
        "logs/zhao_jamming/receiver.log",
    threads: 1
    resources:
        mem_mb=RES.mem_mb("zhao_receiver"),
        runtime=RES.runtime("zhao_receiver"),
    script:
        "../scripts/zhao_receiver.py"


rule zhao_cn0_sweep_point:
    """Every channel with the jammed C/N0 set to one value of the sweep (where each variant breaks)."""
    input:
        dataset=GPS_DATASET,
        ephemerides=EPHEMERIDES,
        prediction=paths.ZHAO_BIT_PREDICTION,
    output:
        ensure(paths.zhao_sweep_point("{cn0}"), non_empty=True),
    params:
        receiver=P.zhao_sweep(config),  # the receiver settings a sweep point reads (no receiver.trials)
        code=code("zhao_sweep_point.py"),
    log:
        "logs/zhao_jamming/cn0_sweep_{cn0}.log",
    threads: 1
    resources:
        mem_mb=RES.mem_mb("zhao_cn0_sweep_point"),
        runtime=RES.runtime("zhao_cn0_sweep_point"),
        trial_batch=int(config["zhao_receiver"]["trial_batch"]),  # memory only: not a param (no result depends on it)
    script:
        "../scripts/zhao_sweep_point.py"


# --- Zhao et al.: the pre-declared readings of where the position spread comes from
# (docs/REPRODUCTION.md); every reading runs the receiver's own scripts with its params.

import re

ZR_READINGS = list(config["zhao_readings"]["readings"])
ZR_CLEAN = [r for r in ZR_READINGS if config["zhao_readings"]["readings"][r].get("scenario", "jammed") == "clean"]
GPS_CLEAN_DATASET = paths.gps_clean_dataset_path(config)


if ZR_CLEAN:

    rule zhao_clean_dataset:
        """Truth of the clean scenario: the jammed scenario's dataset with the jammer off for the whole 4 minutes."""
        input:
            ephemerides=EPHEMERIDES,
        output:
            ensure(GPS_CLEAN_DATASET, non_empty=True),
        params:
            dataset=P.zhao_clean_dataset(config),
            code=code("make_gps_jamming.py"),
        log:
            "logs/data/gps_jamming_clean.log",
        threads: 1
        resources:
            mem_mb=RES.mem_mb("gps_jamming_dataset"),
            runtime=RES.runtime("gps_jamming_dataset"),
        script:
            "../scripts/make_gps_jamming.py"


rule zhao_reading_channel:
    """One satellite channel of one pre-declared reading (zhao_readings): the receiver with the reading's overrides."""
    input:
        # a jammed-scenario reading reads the dataset and its bit prediction; a clean one the clean dataset (MM without priors)
        unpack(lambda wc: {"dataset": GPS_CLEAN_DATASET, "ephemerides": EPHEMERIDES} if wc.reading in ZR_CLEAN
               else {"dataset": GPS_DATASET, "ephemerides": EPHEMERIDES, "prediction": paths.ZHAO_BIT_PREDICTION}),
    output:
        ensure(paths.zhao_reading_channel("{reading}", "{prn}"), non_empty=True),
    params:
        receiver=lambda wildcards: P.zhao_reading(config, wildcards.reading),
        code=code("zhao_channel.py"),
    wildcard_constraints:
        reading="|".join(re.escape(r) for r in ZR_READINGS),
        prn=r"\d+",
    log:
        "logs/zhao_jamming/readings/{reading}/channel_prn{prn}.log",
    threads: 1
    resources:
        mem_mb=RES.zhao_channel_mem_mb(config),
        runtime=RES.zhao_channel_runtime(config),
        trial_batch=int(config["zhao_receiver"]["trial_batch"]),  # memory only: not a param (no result depends on it)
    script:
        "../scripts/zhao_channel.py"


rule zhao_reading_receiver:
    """Positions and ENU statistics of one pre-declared reading from its channels."""
    input:
        dataset=lambda wildcards: GPS_CLEAN_DATASET if wildcards.reading in ZR_CLEAN else GPS_DATASET,
        channels=[paths.zhao_reading_channel("{reading}", p) for p in GJ["prns"]],
    output:
        ensure(paths.zhao_reading_receiver("{reading}"), non_empty=True),
    params:
        receiver=lambda wildcards: P.zhao_reading_receiver(config, wildcards.reading),
        code=code("zhao_receiver.py"),
    wildcard_constraints:
        reading="|".join(re.escape(r) for r in ZR_READINGS),
    log:
        "logs/zhao_jamming/readings/{reading}/receiver.log",
    threads: 1
    resources:
        mem_mb=RES.mem_mb("zhao_receiver"),
        runtime=RES.runtime("zhao_receiver"),
    script:
        "../scripts/zhao_receiver.py"
