# Experiment rules (Vila-Valls 2018, Sec. VI-A..D, F; Susi 2014; the cross-paper
# ranking): one job per experiment, ``tracking_<experiment>``, runs every tracker
# on every trial of each of its scenarios and writes one result per scenario.
# A scenario's trials run in ``shards`` blocks, one after the other, merged
# exactly (scintrack.experiments.shard_job).  The rule gets every value its
# results depend on (scenarios, tracker specs, the tracking settings those
# trackers read, seed, sampling, trials, shards) as params, so a config change
# reruns the experiments it touches.  Its code version covers the plug-in
# tracker types it runs (scintrack.jobcode.planned), so editing a plug-in
# reruns exactly the experiments that run one of its types.


for _experiment in config["experiments"]:

    rule:
        name:
            f"tracking_{_experiment}"
        input:
            **experiment_inputs(_experiment),
        output:
            [paths.exp_result(_experiment, s) for s in config["experiments"][_experiment]["scenarios"]],
        params:
            runs=experiment_runs(_experiment),
            code=planned_code(SCRIPTS, "run_experiment.py", trackers=P.tracker_types(config, config["experiments"][_experiment]["trackers"])),
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
