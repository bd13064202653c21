# Publication rules (docs/archive.md): the paper-vs-reproduced page, the
# byte-reproducible bundle and its verification.


rule compare:
    """Every reproduced table cell beside the paper's value, with a verdict per data kind and per table."""
    input:
        TWINS,
    output:
        md=COMPARE_PAGE[0],
        html=report(COMPARE_PAGE[1], caption="../report/compare.rst", category="Summary"),
    params:
        tables=TWIN_TABLES,
        figures=FIGURES_OF_TABLE,
        code=code("compare.py"),
    log:
        "logs/archive/compare.log",
    script:
        "../scripts/compare.py"


rule archive:
    """archive/<name>-<version>.tar.gz: figures, tables, results, metadata, SHA256SUMS.

    Refuses (one line, naming the result) when a result was not computed
    with the config being archived (its config hash differs)."""
    input:
        figures=FIGURE_FILES,
        tables=TABLE_FILES,
        compare=COMPARE_PAGE,
        gallery=GALLERY,
        manifest=DATASET_MANIFEST,
        results=ALL_RESULTS,
        lock=repo_path("environment.lock"),
        registry=REGISTRY,
        figure_sums=FIGURE_SUMS,
        table_sums=TABLE_SUMS,
    output:
        ARCHIVE_FILE,
    params:
        name=config["archive"]["name"],
        version=ARCHIVE_VERSION,
        allow_dirty=config["archive"]["allow_dirty"],
        max_result_mb=config["archive"]["max_result_mb"],
        config=dict(config),
        code=code("make_archive.py"),
    log:
        "logs/archive/archive.log",
    script:
        "../scripts/make_archive.py"


rule verify:
    """Re-check every checksum of the bundle, the results' config hashes against
    the archived config, and the regenerated results' content hashes."""
    input:
        ARCHIVE_FILE,
        ALL_RESULTS,
    output:
        ARCHIVE_FILE.replace(".tar.gz", ".verify.txt"),
    params:
        code=code("verify_archive.py"),
    log:
        "logs/archive/verify.log",
    script:
        "../scripts/verify_archive.py"
