# Experiment rules (Vila-Valls 2018, Sec. VI-A..D, F): each (experiment,
# scenario) runs as shards of trials, merged exactly into one NetCDF.


wildcard_constraints:
    experiment=r"[^/]+",
    scenario=r"[^/]+",


rule tracking_shard:
    """Run every tracker of an experiment on one block of trials of one scenario."""
    input:
        lut=AR_LUT,
    output:
        temp("results/experiments/{experiment}/{scenario}/shard-{shard}.nc"),
    params:
        trials=lambda wc: shard_trials(wc.experiment, int(wc.shard)),
        trackers=lambda wc: config["experiments"][wc.experiment]["trackers"],
        code=CODE_TRACKING,
    wildcard_constraints:
        shard=r"\d+",
    log:
        "logs/experiments/{experiment}/{scenario}/shard-{shard}.log",
    benchmark:
        "results/benchmarks/tracking_shard/{experiment}/{scenario}/shard-{shard}.tsv"
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
    log:
        "logs/experiments/{experiment}/{scenario}/merge.log",
    script:
        "../scripts/merge_tracking.py"
