# Vila-Valls 2018, Sec. VI-E: multi-frequency scintillation traces.
# Real JRC traces when real_traces.sources is set (fetched, checksum-verified,
# validated), otherwise the synthetic phase-screen SURROGATE; the rest of the
# chain is the same for both and every output says which it used.

wildcard_constraints:
    event=r"[A-Za-z0-9_-]+",


if RT_SOURCE == "real":

    rule fetch_trace:
        """Obtain one real trace (URL or local path) and verify its sha256 against the registry."""
        output:
            ensure("data/raw/jrc_hanoi/{event}.{fmt}", non_empty=True, sha256=lambda wc: expected_sha256(REGISTRY, registry_name(wc.event))),
        params:
            source=lambda wc: RT["sources"][wc.event],
            name=lambda wc: registry_name(wc.event),
            registry=REGISTRY,
            tofu=RT["trust_on_first_use"],
            code=code("fetch_trace.py"),
        wildcard_constraints:
            fmt=r"nc|mat|npz|csv",
        log:
            "logs/data/fetch_{event}_{fmt}.log",
        script:
            "../scripts/fetch_trace.py"

    rule trace_dataset:
        """Validate a real trace against docs/data.md and store it in the canonical format."""
        input:
            lambda wc: raw_trace_path(wc.event),
        output:
            "data/traces/real/{event}.nc",
        params:
            trace=lambda wc: P.trace_input(config, wc.event),
            code=code("trace_dataset.py"),
        log:
            "logs/data/trace_{event}.log",
        script:
            "../scripts/trace_dataset.py"

else:

    rule surrogate_event:
        """SYNTHETIC SURROGATE of one JRC event: multi-frequency phase screen."""
        output:
            ensure("data/synthetic/surrogate_{event}/{version}.nc", non_empty=True),
        params:
            dataset=lambda wc: P.trace_input(config, wc.event)["surrogate"],
            code=code("make_surrogate.py"),
        log:
            "logs/data/surrogate_{event}_{version}.log",
        benchmark:
            "results/benchmarks/surrogate_event/{event}_{version}.tsv"
        threads: 1
        resources:
            mem_mb=RES.mem_mb("surrogate_event"),
            runtime=RES.runtime("surrogate_event"),
        script:
            "../scripts/make_surrogate.py"


rule trace_ar_models:
    """AR models fitted on the first real_traces.fit_s seconds of every band of one event."""
    input:
        lambda wc: TRACE_FILES[wc.event],
    output:
        paths.trace_models_path(config, "{event}"),
    params:
        run=lambda wc: P.trace_models(config, wc.event),
        code=code("trace_ar_models.py"),
    log:
        f"logs/real_traces/{RT_SOURCE}/ar_models_{{event}}.log",
    threads: 1
    resources:
        mem_mb=RES.mem_mb("trace_ar_models"),
        runtime=RES.runtime("trace_ar_models"),
    script:
        "../scripts/trace_ar_models.py"


rule trace_diagnostics:
    """S4 over time of every event and band; PACF of severe/moderate/low segments (Figs. 12-14)."""
    input:
        **TRACE_FILES,
    output:
        paths.trace_diagnostics_path(config),
    params:
        run=P.trace_diagnostics(config),
        code=code("trace_diagnostics.py"),
    log:
        f"logs/real_traces/{RT_SOURCE}/diagnostics.log",
    threads: 1
    resources:
        mem_mb=RES.mem_mb("trace_diagnostics"),
        runtime=RES.runtime("trace_diagnostics"),
    script:
        "../scripts/trace_diagnostics.py"


rule trace_tracking:
    """Dynamics-free scintillation tracking with the AEKF-AR (Fig. 11, Table V) and every
    tracker on the trace plus the aeronautical dynamics (Fig. 15, Tables VI, VIII), on one event."""
    input:
        trace=lambda wc: TRACE_FILES[wc.event],
        models=paths.trace_models_path(config, "{event}"),
        lut=AR_LUT,
    output:
        static=paths.trace_static_path(config, "{event}"),
        dynamics=paths.trace_dynamics_path(config, "{event}"),
    params:
        static=lambda wc: P.trace_static(config, wc.event),
        dynamics=lambda wc: P.trace_dynamics(config, wc.event),
        code=code("trace_experiment.py"),
    log:
        f"logs/real_traces/{RT_SOURCE}/tracking_{{event}}.log",
    benchmark:
        f"results/benchmarks/trace_tracking/{RT_SOURCE}_{{event}}.tsv"
    threads: 1
    resources:
        mem_mb=RES.mem_mb("trace_tracking"),
        runtime=RES.runtime("trace_tracking"),
    script:
        "../scripts/trace_experiment.py"
