# Figure rules: read results, never simulate.  Each figure is a rule named
# after it (``snakemake --cores 2 fig01``) and a report() output.  The list of
# figures, their inputs and arguments is declared on the figure functions
# themselves (decorators in src/scintrack/products/figures/*.py, see
# src/scintrack/products/registry.py); a rule owns the checksum manifest.
# Beside each figure, <stem>.json holds what the gallery shows (its paper
# figure, the paper's claim, our verdict, the data kind) and the problems of
# the layout check (scintrack.products.figure_check).

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
            json=_out["json"],
        params:
            product=_name,
            module=_product.module,
            kwargs=_product.kwargs(config),
            data=_product.data_kind(config),
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


rule gallery:
    """figures/index.md and index.html: every figure with its paper figure, the paper's claim, our verdict and its data."""
    input:
        records=[p.outputs(config)["json"] for p in FIGURES.values()],
        images=[p.outputs(config)["png"] for p in FIGURES.values()],
    output:
        md=GALLERY[0],
        html=report(GALLERY[1], caption="../report/gallery.rst", category="Summary"),
    params:
        code=code("render_gallery.py"),
    log:
        "logs/figures/gallery.log",
    script:
        "../scripts/render_gallery.py"
