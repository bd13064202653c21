# Experiment rules (Vila-Valls 2018, Sec. VI-A..D, F): each (experiment,
# scenario) runs as shards of trials, merged exactly into one NetCDF.  Both
# rules get every value the result depends on (scenario, tracker specs, the
# tracking settings those trackers read, seed, sampling, trials) as params.


wildcard_constraints:
    experiment=r"[^/]+",
    scenario=r"[^/]+",


rule tracking_shard:
    """Run every tracker of an experiment on one block of trials of one scenario."""
    input:
        unpack(shard_inputs),
    output:
        temp("results/experiments/{experiment}/{scenario}/shard-{shard}.nc"),
    params:
        run=lambda wc: {**experiment_params(wc), "trials": P.shard_trials(config, wc.experiment, int(wc.shard))},
        code=code("run_tracking_shard.py"),
    wildcard_constraints:
        shard=r"\d+",
    log:
        "logs/experiments/{experiment}/{scenario}/shard-{shard}.log",
    benchmark:
        "results/benchmarks/tracking_shard/{experiment}/{scenario}/shard-{shard}.tsv"
    threads: 1
    resources:
        mem_mb=lambda wc: RES.shard_mem_mb(config, wc.experiment, wc.scenario, int(wc.shard)),
        runtime=lambda wc: RES.shard_runtime(config, wc.experiment, wc.scenario, int(wc.shard)),
    script:
        "../scripts/run_tracking_shard.py"


rule tracking_merge:
    """Merge the shards of one (experiment, scenario) and add RMSE/CI statistics."""
    input:
        lambda wc: expand(
            "results/experiments/{experiment}/{scenario}/shard-{shard}.nc",
            experiment=wc.experiment, scenario=wc.scenario,
            shard=range(int(config["experiments"][wc.experiment]["shards"])),
        ),
    output:
        "results/experiments/{experiment}/{scenario}.nc",
    params:
        run=experiment_params,
        code=code("merge_tracking.py"),
    log:
        "logs/experiments/{experiment}/{scenario}/merge.log",
    threads: 1
    resources:
        mem_mb=RES.mem_mb("tracking_merge"),
        runtime=RES.runtime("tracking_merge"),
    script:
        "../scripts/merge_tracking.py"
