# Susi, Andreotti & Aquino 2014: the traces of its two 1-ms scenarios (the
# high-latitude SURROGATE always; the equatorial real JRC trace when
# configured, else its SURROGATE) and their scintillation indices.  The
# tracking itself runs through the experiment rules (experiments.smk).

rule susi_surrogate:
    """SYNTHETIC SURROGATE scintillation of one Susi trace (phase screen, L1, at the scenario's Ts)."""
    output:
        ensure("data/synthetic/susi_surrogate_{name}/{version}.nc", non_empty=True),
    params:
        dataset=lambda wc: P.susi_trace(config, wc.name)["surrogate"],
        setting=lambda wc: f"susi_2014.traces.{wc.name}.surrogate",
        code=code("make_surrogate.py"),
    wildcard_constraints:
        name=r"[A-Za-z0-9_-]+",
    log:
        "logs/data/susi_surrogate_{name}_{version}.log",
    benchmark:
        "results/benchmarks/susi_surrogate/{name}_{version}.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("susi_surrogate"),
        runtime=RES.runtime("susi_surrogate"),
    script:
        "../scripts/make_surrogate.py"


rule susi_indices:
    """S4 and Phi60 (60 s), Phi3 and T, p (3 s) of one Susi scenario (Figs. 3 and 6)."""
    input:
        trace=lambda wc: paths.scenario_trace_path(config, wc.scenario),
    output:
        paths.susi_indices_path("{scenario}"),
    params:
        run=lambda wc: P.susi_indices(config, wc.scenario),
        code=code("susi_indices.py"),
    log:
        "logs/susi_2014/indices_{scenario}.log",
    threads: 1
    resources:
        mem_mb=RES.mem_mb("susi_indices"),
        runtime=RES.runtime("susi_indices"),
    script:
        "../scripts/susi_indices.py"
