# Experiment rules (Vila-Valls 2018, Sec. VI-A..D, F): each (experiment,
# scenario) runs as shards of trials, merged exactly into one NetCDF (or, with
# one shard, as one job that does both).  Both
# rules get every value the result depends on (scenario, tracker specs, the
# tracking settings those trackers read, seed, sampling, trials) as params.


wildcard_constraints:
    experiment=r"[^/]+",
    scenario=r"[^/]+",


# An experiment with shards > 1 runs as tracking_shard jobs + one tracking_merge per
# scenario; with shards: 1 as one tracking_single job (shard and merge in one
# process: one job start-up less per result, the same content bit for bit).
_MULTI_SHARD = P.experiment_names_regex(config, multi_shard=True)
_SINGLE_SHARD = P.experiment_names_regex(config, multi_shard=False)


rule tracking_single:
    """Run every tracker of a single-shard experiment on all trials of one scenario and merge, in one job."""
    input:
        unpack(shard_inputs),
    output:
        "results/experiments/{experiment}/{scenario}.nc",
    params:
        run=experiment_params,
        code=code("run_tracking_single.py"),
    wildcard_constraints:
        experiment=_SINGLE_SHARD,
    log:
        "logs/experiments/{experiment}/{scenario}/single.log",
    benchmark:
        "results/benchmarks/tracking_single/{experiment}/{scenario}.tsv"
    threads: 1
    resources:
        mem_mb=lambda wc: RES.shard_mem_mb(config, wc.experiment, wc.scenario, 0),
        runtime=lambda wc: RES.shard_runtime(config, wc.experiment, wc.scenario, 0),
    script:
        "../scripts/run_tracking_single.py"


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
        experiment=_MULTI_SHARD,
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
    wildcard_constraints:
        experiment=_MULTI_SHARD,
    log:
        "logs/experiments/{experiment}/{scenario}/merge.log",
    threads: 1
    resources:
        mem_mb=RES.mem_mb("tracking_merge"),
        runtime=RES.runtime("tracking_merge"),
    script:
        "../scripts/merge_tracking.py"
