# Figure rules: read results, never simulate.  Each figure is a rule named
# after it (``snakemake --cores 2 fig01``) and a report() output.  The list of
# figures, their inputs and arguments is declared on the figure functions
# themselves (decorators in src/scintrack/products/figures/*.py, see
# src/scintrack/products/registry.py); a rule owns the checksum manifest.

for _name, _product in FIGURES.items():
    _out = _product.outputs(config)

    rule:
        name:
            _name
        input:
            **_product.inputs(config),
        output:
            pdf=report(_out["pdf"], caption=f"../report/{_name}.rst", category=PAPERS[_product.paper], subcategory=report_section(_product)),
            png=_out["png"],
        params:
            product=_name,
            module=_product.module,
            kwargs=_product.kwargs(config),
            code=code("render_figure.py", _product.module),
        log:
            f"logs/figures/{_name}.log",
        script:
            "../scripts/render_figure.py"


rule figure_checksums:
    """figures/SHA256SUMS: sha256sum-format list of every figure file."""
    input:
        FIGURE_FILES,
    output:
        FIGURE_SUMS,
    params:
        code=code("checksums.py"),
    log:
        "logs/figures/checksums.log",
    script:
        "../scripts/checksums.py"
