# Publication rules (docs/archive.md): the paper-vs-reproduced page, the
# byte-reproducible bundle and its verification.


rule compare:
    """Every reproduced table cell beside the paper's value, with a summary line."""
    input:
        VV_TWINS,
    output:
        md=COMPARE_PAGE[0],
        html=report(COMPARE_PAGE[1], caption="../report/compare.rst", category="Summary"),
    params:
        code=code_hash("archive"),
    log:
        "logs/archive/compare.log",
    script:
        "../scripts/compare.py"


rule archive:
    """archive/<name>-<version>.tar.gz: figures, tables, results, metadata, SHA256SUMS."""
    input:
        figures=VV_FIGURES,
        tables=VV_TABLES,
        compare=COMPARE_PAGE,
        manifest=DATASET_MANIFEST,
        results=ALL_RESULTS,
        lock=repo_path("environment.lock"),
        registry=REGISTRY,
        figure_sums="figures/SHA256SUMS",
        table_sums="tables/SHA256SUMS",
    output:
        ARCHIVE_FILE,
    params:
        name=config["archive"]["name"],
        version=ARCHIVE_VERSION,
        code=code_hash("archive"),
    log:
        "logs/archive/archive.log",
    script:
        "../scripts/make_archive.py"


rule verify:
    """Re-check every checksum of the bundle and the regenerated results' content hashes."""
    input:
        ARCHIVE_FILE,
        ALL_RESULTS,
    output:
        ARCHIVE_FILE.replace(".tar.gz", ".verify.txt"),
    log:
        "logs/archive/verify.log",
    script:
        "../scripts/verify_archive.py"
