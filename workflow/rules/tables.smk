# Table rules: read results, write CSV + Markdown and a paper-vs-reproduced
# twin.  The list of tables, their inputs and output stems is declared on the
# table functions themselves (decorators in src/scintrack/products/tables/*.py, see
# src/scintrack/products/registry.py); a rule owns the checksum manifest.

for _name, _product in TABLES.items():

    rule:
        name:
            _name
        input:
            **_product.inputs(config),
        output:
            **{k: (report(v, caption=f"../report/{_name}.rst", category=PAPERS[_product.paper], subcategory=report_section(_product)) if k.endswith("_csv") else v)
               for k, v in _product.outputs(config).items()},
        params:
            product=_name,
            module=_product.module,
            code=code("render_table.py", _product.module),
        log:
            f"logs/tables/{_name}.log",
        script:
            "../scripts/render_table.py"


rule table_checksums:
    """tables/SHA256SUMS: sha256sum-format list of every table file and the comparison page."""
    input:
        TABLE_FILES,
        COMPARE_PAGE,
    output:
        TABLE_SUMS,
    params:
        code=code("checksums.py"),
    log:
        "logs/tables/checksums.log",
    script:
        "../scripts/checksums.py"


rule ranking:
    """The cross-paper ranking alone: table_ranking and fig_ranking (with its gallery record) and the experiments they read.
    `snakemake --cores 2 ranking --configfile my_trackers.yaml` ranks the trackers an overlay adds (docs/adding-a-tracker.md)."""
    input:
        list(TABLES["table_ranking"].outputs(config).values()),
        list(FIGURES["fig_ranking"].outputs(config).values()),
