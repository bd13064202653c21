# Experiment rules (Vila-Valls 2018, Sec. VI-A..D, F; Susi 2014; the cross-paper
# ranking): every tracker of an experiment on every trial of its scenarios.
# Every rule gets the values its results depend on (scenario, tracker specs,
# the tracking settings those trackers read, seed, sampling, trials) as params.
#
# Two grains, chosen per experiment by its ``shards`` value in the config:
# - ``shards: 1``: one job per experiment (rule ``tracking_<experiment>``) runs
#   its scenarios one after the other, each written to its own result file;
#   the trackers are imported once for all scenarios.
# - ``shards: k > 1``: each (experiment, scenario) runs as k ``tracking_shard``
#   jobs over blocks of trials (they bound memory and spread a long Monte
#   Carlo over the cores) and one ``tracking_merge``.
# Both give the same content bit for bit (tests/test_speed_paths.py).


wildcard_constraints:
    experiment=r"[^/]+",
    scenario=r"[^/]+",


_MULTI_SHARD = P.experiment_names_regex(config, multi_shard=True)


for _experiment in P.single_shard_experiments(config):

    rule:
        name:
            f"tracking_{_experiment}"
        input:
            **experiment_inputs(_experiment),
        output:
            [paths.exp_result(_experiment, s) for s in config["experiments"][_experiment]["scenarios"]],
        params:
            runs=experiment_runs(_experiment),
            code=code("run_experiment.py"),
        log:
            f"logs/experiments/{_experiment}.log",
        benchmark:
            f"results/benchmarks/tracking_experiment/{_experiment}.tsv"
        threads: 1
        resources:
            mem_mb=RES.experiment_mem_mb(config, _experiment),
            runtime=RES.experiment_runtime(config, _experiment),
        script:
            "../scripts/run_experiment.py"


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
