# AR model rules (Vila-Valls 2018, Sec. III-B/C): fits per S4, the look-up
# table over the (S4, tau0) grid, and the diagnostics behind Figs. 1-4.


rule ar_fit:
    """AR(1..max_order), PACF and PACF/AIC/BIC orders for one training set."""
    input:
        lambda wc: training_path(wc.s4),
    output:
        "results/ar_models/fits/s4-{s4}.nc",
    params:
        fit=lambda wc: P.ar_fit(config, wc.s4),
        code=code("fit_ar.py"),
    log:
        "logs/ar_models/fit_s4-{s4}.log",
    benchmark:
        "results/benchmarks/ar_fit/s4-{s4}.tsv"
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
    script:
        "../scripts/ar_diagnostics.py"
