# Table rules: read results, write CSV + Markdown and a paper-vs-reproduced twin.


rule table01:
    """Table I: AR model orders per scintillation region, beside the paper's."""
    input:
        lut=AR_LUT,
    output:
        csv=report(VV_TABLES[0], caption="../report/table01.rst", category="Vila-Valls 2018", subcategory="Sec. III: AR models"),
        md=VV_TABLES[1],
        twin_csv=report(VV_TABLES[2], caption="../report/table01.rst", category="Vila-Valls 2018", subcategory="Sec. III: AR models"),
        twin_md=VV_TABLES[3],
        length_csv=report(VV_TABLES[4], caption="../report/table01.rst", category="Vila-Valls 2018", subcategory="Sec. III: AR models"),
        length_md=VV_TABLES[5],
    params:
        code=CODE_TABLES,
    log:
        "logs/tables/table01.log",
    script:
        "../scripts/table01.py"


# Tables of Sec. VI: each function returns {stem: (frame, title, note)}; the
# list is VV_TABLE_SPECS in common.smk.
for _name, (_function, _tinputs) in VV_TABLE_SPECS.items():

    rule:
        name:
            _name
        input:
            **_tinputs,
        output:
            **{f"{stem}_csv": report(f"{VV_TAB}/{VV_TABLE_FILE[stem]}.csv", caption=f"../report/{_name}.rst", category="Vila-Valls 2018", subcategory=_RT if _name in ("table05", "table06", "table08", "tableS3") else "Sec. VI: tracking on CSM data") for stem in VV_TABLE_STEMS[_name]},
            **{f"{stem}_md": f"{VV_TAB}/{VV_TABLE_FILE[stem]}.md" for stem in VV_TABLE_STEMS[_name]},
        params:
            module=VV_MODULE.get(_name, "scintrack.tables.vila_valls_2018"),
            function=_function,
            code=CODE_TABLES,
        log:
            f"logs/tables/{_name}.log",
        script:
            "../scripts/render_table.py"
