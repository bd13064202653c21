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
    log:
        "logs/tables/table01.log",
    script:
        "../scripts/table01.py"
