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


rule susi_index_trace:
    """SURROGATE trace of the real-index event: the pre-declared run of REAL BiScEF minutes, a phase with each minute's real slope p."""
    input:
        indices=P.SUSI_BISCEF_INDICES,
    output:
        ensure("data/synthetic/susi_index_{name}/{version}.nc", non_empty=True),
    params:
        dataset=lambda wc: P.susi_trace(config, wc.name)["real_indices"],
        code=code("make_index_trace.py"),
    wildcard_constraints:
        name=r"[A-Za-z0-9_-]+",
    log:
        "logs/data/susi_index_{name}_{version}.log",
    benchmark:
        "results/benchmarks/susi_index_trace/{name}_{version}.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("susi_index_trace"),
        runtime=RES.runtime("susi_index_trace"),
    script:
        "../scripts/make_index_trace.py"


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


rule susi_biscef_indices:
    """REAL Septentrio scintillation indices (BiScEF, Tromso and Ny-Alesund, 2023-01-15): GPS L1 rows at elevation >= 20 deg and the minute with the largest Phi60."""
    input:
        **{entry: repo_path(spec["path"]) for entry, spec in P.susi_biscef(config)["files"].items()},
    output:
        P.SUSI_BISCEF_INDICES,
    params:
        run=P.susi_biscef(config),
        code=code("biscef_indices.py"),
    log:
        "logs/susi_2014/biscef_indices.log",
    benchmark:
        "results/benchmarks/susi_biscef_indices.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("susi_biscef_indices"),
        runtime=RES.runtime("susi_biscef_indices"),
    script:
        "../scripts/biscef_indices.py"


rule susi_jitter_bound:
    """The smallest 1-ms discriminator jitter a linear causal tracker can reach on each scenario of the chapter run (Kolmogorov-Szego and Wiener bounds) and the best third-order loop (2-40 Hz); the jitter table shows them beside its cells."""
    input:
        traces=[paths.scenario_trace_path(config, sc) for sc in P.susi_jitter_bound(config)["scenarios"]],
    output:
        P.SUSI_JITTER_BOUND,
    params:
        run=P.susi_jitter_bound(config),
        code=code("jitter_bound.py"),
    log:
        "logs/susi_2014/jitter_bound.log",
    benchmark:
        "results/benchmarks/susi_jitter_bound.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("susi_jitter_bound"),
        runtime=RES.runtime("susi_jitter_bound"),
    script:
        "../scripts/jitter_bound.py"


rule susi_akf_bandwidth:
    """Steady-state loop bandwidth of the AKF PLLs of the q_jerk sweep (experiment susi_akf_qjerk) per Q term: oscillator only, q_jerk only, both."""
    output:
        P.SUSI_AKF_BANDWIDTH,
    params:
        run=P.susi_akf_bandwidth(config),
        code=code("akf_bandwidth.py"),
    log:
        "logs/susi_2014/akf_bandwidth.log",
    benchmark:
        "results/benchmarks/susi_akf_bandwidth.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("susi_akf_bandwidth"),
        runtime=RES.runtime("susi_akf_bandwidth"),
    script:
        "../scripts/akf_bandwidth.py"


# --- Susi readings U1-U4 of eqs. (7)-(8) (pre-declared, docs/REPRODUCTION.md) ---------------------------

rule susi_readings_loops:
    """Steady-state loop bandwidth of each reading of eqs. (7)-(8) (experiment susi_readings) at its median on-line T, p and weight."""
    input:
        **{f"result_{sc}": paths.exp_result(P.SUSI_READINGS_EXPERIMENT, sc) for sc in P.susi_readings_loops(config)["scenarios"]},
    output:
        P.SUSI_READINGS_LOOPS,
    params:
        run=P.susi_readings_loops(config),
        code=code("susi_readings_loops.py"),
    log:
        "logs/susi_2014/readings_loops.log",
    benchmark:
        "results/benchmarks/susi_readings_loops.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("susi_readings_loops"),
        runtime=RES.runtime("susi_readings_loops"),
    script:
        "../scripts/susi_readings_loops.py"
