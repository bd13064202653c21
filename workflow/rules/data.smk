# Data rules: synthetic datasets (versioned by a hash of generator + parameters)
# and the dataset manifest built from their attributes.


rule csm_training_set:
    """CSM amplitude/phase for one S4 over the tau0 grid (AR training data)."""
    output:
        ensure("data/synthetic/csm_train_s4-{s4}/{version}.nc", non_empty=True),
    params:
        dataset=lambda wc: P.training(config, wc.s4),
        code=code("make_csm_training.py"),
    log:
        "logs/data/csm_train_s4-{s4}_{version}.log",
    benchmark:
        "results/benchmarks/csm_training_set/s4-{s4}_{version}.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("csm_training_set"),
        runtime=RES.runtime("csm_training_set"),
    script:
        "../scripts/make_csm_training.py"


rule dataset_manifest:
    """Name, version, source and checksums of every dataset of this run."""
    input:
        TRAINING_SETS,
        list(TRACE_FILES.values()),
        [f for f in SUSI_TRACE_FILES if f not in TRACE_FILES.values()],
        paths.gps_dataset_path(config),
        [v for k, v in paths.gps_iq_paths(config).items() if k.endswith("_sidecar")],
    output:
        DATASET_MANIFEST,
    params:
        code=code("dataset_manifest.py"),
    log:
        "logs/data/dataset_manifest.log",
    script:
        "../scripts/dataset_manifest.py"
