# AR model rules (Vila-Valls 2018, Sec. III-B/C): fits per S4, the look-up
# table over the (S4, tau0) grid, and the diagnostics behind Figs. 1-4.


rule ar_fit:
    """AR(1..max_order), PACF and PACF/AIC/BIC orders for one training set: the phase
    models fitted on the unwrapped phase and, for reading R5, on the wrapped phase
    (the amplitude fits are the same series, fitted once)."""
    input:
        train=lambda wc: training_path(wc.s4),
    output:
        unwrapped="results/ar_models/fits/s4-{s4}.nc",
        wrapped="results/ar_models/wrapped/fits/s4-{s4}.nc",
    params:
        fit=lambda wc: P.ar_fit(config, wc.s4),
        fit_wrapped=lambda wc: P.ar_fit(config, wc.s4, "wrapped"),
        code=code("fit_ar.py"),
    log:
        "logs/ar_models/fit_s4-{s4}.log",
    benchmark:
        "results/benchmarks/ar_fit/s4-{s4}.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("ar_fit"),
        runtime=RES.runtime("ar_fit"),
    script:
        "../scripts/fit_ar.py"


rule ar_lut:
    """AR look-up table (S4 x tau0 x component) read by the trackers."""
    input:
        [paths.ar_fit_path(s4) for s4 in TRAIN_S4],
    output:
        AR_LUT,
    params:
        lut=P.ar_lut(config),
        code=code("merge_lut.py"),
    log:
        "logs/ar_models/ar_lut.log",
    benchmark:
        "results/benchmarks/ar_lut.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("ar_lut"),
        runtime=RES.runtime("ar_lut"),
    script:
        "../scripts/merge_lut.py"


rule ar_diagnostics:
    """Welch PSD, AR(1..4) model PSDs and PACF of the Figs. 1-4 cases."""
    input:
        fits=sorted({paths.ar_fit_path(c["s4"]) for c in config["figures"]["vila_valls_2018"]["ar_cases"].values()}),
        train=sorted({training_path(c["s4"]) for c in config["figures"]["vila_valls_2018"]["ar_cases"].values()}),
    output:
        VV_DIAGNOSTICS,
    params:
        diag=P.ar_diagnostics(config),
        code=code("ar_diagnostics.py"),
    log:
        "logs/vila_valls_2018/ar_diagnostics.log",
    threads: 1
    resources:
        mem_mb=RES.mem_mb("ar_diagnostics"),
        runtime=RES.runtime("ar_diagnostics"),
    script:
        "../scripts/ar_diagnostics.py"


rule ar_lut_wrapped:
    """The AR look-up table of the wrapped-phase fits (reading R5)."""
    input:
        [paths.ar_fit_path(s4, "wrapped") for s4 in TRAIN_S4],
    output:
        paths.AR_LUT_WRAPPED,
    params:
        lut=P.ar_lut(config, "wrapped"),
        code=code("merge_lut.py"),
    log:
        "logs/ar_models/wrapped/ar_lut.log",
    threads: 1
    resources:
        mem_mb=RES.mem_mb("ar_lut_wrapped"),
        runtime=RES.runtime("ar_lut_wrapped"),
    script:
        "../scripts/merge_lut.py"


# Achievability floors of the theta_d error on the Table III cells.
rule vv_floors:
    """Riccati bound of the AEKF-AR's model and GLS floors in the CSM world (readings R1, R2), one file per cell."""
    input:
        lut=AR_LUT,
    output:
        [paths.floors_path(s) for s in config["floors"]["scenarios"]],
    params:
        runs={s: P.floors(config, s) for s in config["floors"]["scenarios"]},
        code=code("floors.py"),
    log:
        "logs/vila_valls_2018/floors.log",
    benchmark:
        "results/benchmarks/vv_floors.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("vv_floors"),
        runtime=RES.runtime("vv_floors"),
    script:
        "../scripts/floors.py"
