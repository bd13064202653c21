# Reproduction of three GNSS carrier-tracking papers; reads like their contents.
#
#   snakemake --cores 2                 everything
#   snakemake --cores 2 fig01           one figure (and only what it needs)
#   snakemake --cores 2 --configfile config/smoke.yaml   tiny sizes, same DAG
#
# Data flow (one way): config -> datasets -> AR models -> results -> figures/tables.

import os

from snakemake.utils import min_version

min_version("9.0")


configfile: os.path.join(workflow.basedir, "config", "config.yaml")


include: "workflow/rules/common.smk"


rule all:
    default_target: True
    input:
        DATASET_MANIFEST,
        VV_FIGURES,
        VV_TABLES,
        COMPARE_PAGE,


# Vila-Valls et al. 2018, Sec. III: CSM data and AR scintillation models.
include: "workflow/rules/data.smk"
include: "workflow/rules/ar_models.smk"


# Sec. VI-A..D and F: five trackers on CSM data (experiments -> figures/tables).
include: "workflow/rules/experiments.smk"


# Sec. VI-E: real multi-frequency traces (or their labelled surrogate).
include: "workflow/rules/real_traces.smk"


# Publication: paper-vs-reproduced page, checksummed bundle, verification.
include: "workflow/rules/archive.smk"
include: "workflow/rules/figures.smk"
include: "workflow/rules/tables.smk"
