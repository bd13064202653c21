"""What the Snakemake workflow needs from the package: where results live
(:mod:`.paths`), which config values each result depends on (:mod:`.params`)
and the check that a result was computed with a given config (:mod:`.consistency`)."""
