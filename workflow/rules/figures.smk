# Figure rules: read results, never simulate.  Each figure is a rule named
# after it (``snakemake --cores 2 fig01``) and a report() output.

VV_PACF_LAGS = config["figures"]["vila_valls_2018"]["pacf_lags_shown"]


def _vv_figure_rule(name, kwargs):
    stem = VV_FIGURE_STEMS[name]

    rule:
        name:
            name
        input:
            diag=VV_DIAGNOSTICS,
        output:
            pdf=report(f"{VV_FIG}/{stem}.pdf", caption=f"../report/{name}.rst", category="Vila-Valls 2018", subcategory="Sec. III: AR models"),
            png=f"{VV_FIG}/{stem}.png",
        params:
            module="scintrack.figures.vila_valls_2018",
            function=name,
            kwargs=kwargs,
        log:
            f"logs/figures/{name}.log",
        script:
            "../scripts/render_figure.py"


_vv_figure_rule("fig01", {})
_vv_figure_rule("fig02", {"lags_shown": VV_PACF_LAGS})
_vv_figure_rule("fig03", {})
_vv_figure_rule("fig04", {"lags_shown": VV_PACF_LAGS})
