# AR model rules (Vila-Valls 2018, Sec. III-B/C): fits per S4, the look-up
# table over the (S4, tau0) grid, and the diagnostics behind Figs. 1-4.


rule ar_fit:
    """AR(1..max_order), PACF and PACF/AIC/BIC orders for one training set."""
    input:
        train=lambda wc: training_path(wc.s4),
    output:
        "results/ar_models/fits/s4-{s4}.nc",
    params:
        fit=lambda wc: P.ar_fit(config, wc.s4),
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


# Reading R5 of the Vila-Valls simulation (issue 13): the same fits with the
# phase models fitted on the wrapped phase, only when an experiment asks for
# them (experiments.<name>.lut: wrapped).
rule ar_fit_wrapped:
    """AR fits of one training set with the phase models on the wrapped phase (amplitude fits copied from ar_fit)."""
    input:
        train=lambda wc: training_path(wc.s4),
        unwrapped="results/ar_models/fits/s4-{s4}.nc",
    output:
        "results/ar_models/wrapped/fits/s4-{s4}.nc",
    params:
        fit=lambda wc: P.ar_fit(config, wc.s4, "wrapped"),
        code=code("fit_ar.py"),
    log:
        "logs/ar_models/wrapped/fit_s4-{s4}.log",
    threads: 1
    resources:
        mem_mb=RES.mem_mb("ar_fit_wrapped"),
        runtime=RES.runtime("ar_fit_wrapped"),
    script:
        "../scripts/fit_ar.py"


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


# Issue 13: achievability floors of the theta_d error per Table III cell.
rule vv_floors:
    """Riccati bound of the AEKF-AR's model and GLS floors in the CSM world (readings R1, R2) for one cell."""
    input:
        lut=AR_LUT,
    output:
        paths.floors_path("{scenario}"),
    params:
        run=lambda wc: P.floors(config, wc.scenario),
        code=code("floors.py"),
    log:
        "logs/vila_valls_2018/floors_{scenario}.log",
    benchmark:
        "results/benchmarks/vv_floors/{scenario}.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("vv_floors"),
        runtime=RES.runtime("vv_floors"),
    script:
        "../scripts/floors.py"
