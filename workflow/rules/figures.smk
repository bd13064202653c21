# Figure rules: read results, never simulate.  Each figure is a rule named
# after it (``snakemake --cores 2 fig01``) and a report() output; the list of
# figures, their inputs and arguments is VV_FIGURE_SPECS in common.smk.

for _name, (_inputs_, _kwargs, _subcat) in VV_FIGURE_SPECS.items():

    rule:
        name:
            _name
        input:
            **_inputs_,
        output:
            pdf=report(f"{VV_FIG}/{VV_FIGURE_STEMS[_name]}.pdf", caption=f"../report/{_name}.rst", category="Vila-Valls 2018", subcategory=_subcat),
            png=f"{VV_FIG}/{VV_FIGURE_STEMS[_name]}.png",
        params:
            module=VV_MODULE.get(_name, "scintrack.figures.vila_valls_2018"),
            function=_name,
            kwargs=_kwargs,
            code=CODE_FIGURES,
        log:
            f"logs/figures/{_name}.log",
        script:
            "../scripts/render_figure.py"
