# Reproduction of three GNSS carrier-tracking papers; reads like their contents.
#
#   snakemake --cores 2                 everything
#   snakemake --cores 2 fig01           one figure (and only what it needs)
#   snakemake --cores 2 fig01 --configfile config/smoke.yaml   tiny sizes, same DAG
#                                       (targets BEFORE --configfile: every word after it is read as a config file)
#
# Data flow (one way): config -> datasets -> AR models -> results -> figures/tables.
# Every rule gets the config values its output depends on as params
# (src/scintrack/pipeline/params.py), so an edited value reruns exactly the
# jobs it affects.

import os
import sys

from snakemake.utils import min_version

min_version("9.0")

# Snakemake starts each job's script as `<python> <script>` through bash and
# quotes only the script: an interpreter path with a blank or a shell
# character fails every job (bash: "No such file or directory", exit 127).
if set(sys.executable) & set(" \t\n'\"\\$`;&|<>()*?["):
    sys.exit(
        f"error: the Python running Snakemake ({sys.executable}) has a blank or shell character in its path, "
        "so no job could start; move or clone the project (and its .venv) to a path without them and rerun"
    )

# glibc's allocator keeps freed memory for reuse instead of handing every large
# numpy temporary back to the kernel and faulting in fresh zeroed pages for the
# next one (a fifth of the big jobs' CPU was system time otherwise).  Jobs
# inherit it; results are the same bits; a GLIBC_TUNABLES of your own wins
# (docs/performance.md).
os.environ.setdefault("GLIBC_TUNABLES", "glibc.malloc.mmap_threshold=1073741824:glibc.malloc.trim_threshold=1073741824")

sys.path.insert(0, os.path.join(workflow.basedir, "src"))
from scintrack.config import load_config
from scintrack.errors import ConfigError

_CONFIG_YAML = os.path.join(workflow.basedir, "config", "config.yaml")
try:  # the project's loader names the file and line of a YAML error
    load_config([_CONFIG_YAML])
except ConfigError as _exc:
    sys.exit(f"error: {_exc}")


configfile: _CONFIG_YAML


include: "workflow/rules/common.smk"


onstart:
    # A job killed mid-write leaves its temporary file (never a half-written
    # output); remove those of writers that no longer run (scintrack.atomic).
    from scintrack.atomic import clean_stale

    _removed = clean_stale(OUTPUT_ROOTS)
    if _removed:
        print(f"removed {len(_removed)} temporary file(s) left by an interrupted run", file=sys.stderr)


rule all:
    default_target: True
    input:
        DATASET_MANIFEST,
        FIGURE_FILES,
        TABLE_FILES,
        COMPARE_PAGE,
        GALLERY,
        FIGURE_SUMS,
        TABLE_SUMS,


# Vila-Valls et al. 2018, Sec. III: CSM data and AR scintillation models.
include: "workflow/rules/data.smk"
include: "workflow/rules/ar_models.smk"


# Sec. VI-A..D and F: five trackers on CSM data (experiments -> figures/tables).
include: "workflow/rules/experiments.smk"


# Sec. VI-E: real multi-frequency traces (or their labelled surrogate).
include: "workflow/rules/real_traces.smk"


# Susi, Andreotti & Aquino 2014: the traces of its 1-ms scenarios and their indices
# (its trackers run through the experiment rules above).
include: "workflow/rules/susi.smk"


# Zhao, Khanafseh & Pervan: the jammed SKYDEL-like GPS L1 C/A dataset (truth,
# navigation message, IQ recording) and the results behind its figures.
include: "workflow/rules/gps_jamming.smk"


# Real GPS L1 recordings (Pocket SDR, GNSS-SDR) and the SKYDEL-like segments
# through one chain: reader, acquisition, tracking (docs/real-signals.md).
include: "workflow/rules/real_signals.smk"


# Figures and tables of every paper (declared next to their functions), the
# paper-vs-reproduced page, the checksummed bundle and its verification.
include: "workflow/rules/figures.smk"
include: "workflow/rules/tables.smk"
include: "workflow/rules/archive.smk"
