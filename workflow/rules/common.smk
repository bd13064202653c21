# Shared setup: typed --config overrides, config validation, code versions
# and output paths.  Paths and the config values each result depends on come
# from the package (scintrack.pipeline), so the archive and verify code use
# the same definitions.

import sys
from pathlib import Path

from snakemake.exceptions import WorkflowError
from snakemake.utils import update_config, validate

sys.path.insert(0, str(Path(workflow.basedir) / "src"))

from scintrack.jobcode import planned as planned_code
from scintrack.config import SOURCE, check_consistency, format_validation_error, load_config, locate, typed_overrides
from scintrack.data.registry import expected_sha256
from scintrack.errors import PREFIX, ConfigError, InputError, one_line
from scintrack.project import project_file
from scintrack.pipeline import params as P
from scintrack.pipeline import paths
from scintrack.products import PAPERS, products


def fail(message):
    """Stop with one ``error:`` line (no traceback): a mistake in the user's input."""
    sys.exit(PREFIX + one_line(message))


# Snakemake reads --configfile overlays with its own YAML loader, which keeps
# the last of a key given twice; the project's loader refuses that (file:line, key).
try:
    load_config(workflow.config_settings.configfiles)
except ConfigError as exc:
    fail(exc)


# --config values arrive as strings inside nested mappings ('15.0'); give them
# the types they would have in a YAML config file, then validate everything.
_OVERRIDES = typed_overrides(workflow.config_settings.config)
update_config(config, _OVERRIDES)


def _config_layers():
    """(name, mapping) of every config layer in merge order, to name the one that sets a bad key."""
    layers = [("config/config.yaml", load_config([Path(workflow.basedir) / "config" / "config.yaml"]))]
    for path in workflow.config_settings.configfiles:
        layers.append((str(path), load_config([path])))
    if _OVERRIDES:
        layers.append(("your --config option", _OVERRIDES))
    return layers


def _validate_config():
    try:
        validate(config, "../schemas/config.schema.yaml")
        check_consistency(config, SOURCE)
    except WorkflowError as exc:
        # snakemake.utils.validate raises WorkflowError from inside the
        # handler of the jsonschema ValidationError, which is its context.
        cause = exc.__cause__ or exc.__context__
        if not hasattr(cause, "absolute_path"):
            raise
        fail(locate(format_validation_error(cause, SOURCE), _config_layers()))
    except ConfigError as exc:
        fail(locate(str(exc), _config_layers()))


_validate_config()

SCRIPTS = Path(workflow.basedir) / "workflow" / "scripts"
OUTPUT_ROOTS = ["data", "results", "figures", "tables", "archive", "logs"]  # where the pipeline writes


def code(script, *modules):
    """Code version of a script: the normalised source (AST, no comments or
    docstrings) of the script and of every scintrack module it imports, with
    what it covers; the job checks it against the code it runs (scintrack.jobcode)."""
    return planned_code(SCRIPTS, script, *modules)


# --- Sec. VI-E: real traces, or the synthetic surrogate when none are configured
RT = config["real_traces"]
RT_SOURCE = paths.trace_source(config)
if RT_SOURCE == "surrogate":
    print("real_traces: the JRC traces are not configured (real_traces.sources is empty); Sec. VI-E outputs use the synthetic SURROGATE and say so", file=sys.stderr)


def repo_path(path):
    """A path from the config: absolute, or relative to the working directory if it exists there, else to the repository."""
    return str(project_file(path))


REGISTRY = repo_path(RT["registry"])
try:  # read while the DAG is built (checksums in ensure()): a broken registry is one line here
    expected_sha256(REGISTRY, "")
except InputError as exc:
    fail(exc)


def registry_name(event):
    return f"jrc_hanoi_{event}"


def raw_trace_path(event):
    try:
        return paths.raw_trace_path(config, event)
    except ValueError as exc:
        fail(exc)


TRACE_FILES = {e: paths.trace_path(config, e) for e in RT["events"]}
# Susi 2014: the trace scenarios and the trace files they read
SUSI_SCENARIOS = P.susi_scenarios(config)
SUSI_TRACE_FILES = sorted({paths.scenario_trace_path(config, s) for s in SUSI_SCENARIOS})
TRAIN_S4 = [paths.fmt(s) for s in config["ar_training"]["s4"]]


def training_path(s4):
    return paths.training_path(config, s4)


TRAINING_SETS = [training_path(s) for s in TRAIN_S4]
DATASET_MANIFEST = paths.DATASET_MANIFEST
AR_LUT = paths.AR_LUT
VV_DIAGNOSTICS = paths.VV_DIAGNOSTICS


def experiment_runs(experiment):
    """scenario -> everything that scenario's result depends on, for the one job of an experiment."""
    try:
        return {s: P.experiment(config, experiment, s) for s in config["experiments"][experiment]["scenarios"]}
    except KeyError as exc:
        fail(str(exc).strip("'\""))


def experiment_inputs(experiment):
    """The AR look-up table of an experiment and the trace of each trace scenario (``trace_<scenario>``)."""
    out = {"lut": paths.lut_path(config["experiments"][experiment].get("lut", "unwrapped"))}
    for scenario in config["experiments"][experiment]["scenarios"]:
        try:
            trace = paths.scenario_trace_path(config, scenario)
        except KeyError as exc:
            fail(str(exc).strip("'\""))
        if trace:
            out[f"trace_{scenario}"] = trace
    return out


# --- figures and tables: registered next to their functions (scintrack.products)
FIGURES = products("figure")
TABLES = products("table")
FIGURE_FILES = [f for p in FIGURES.values() for f in p.outputs(config).values()]
TABLE_FILES = [f for p in TABLES.values() for f in p.outputs(config).values()]
COMPARE_PAGE = ["tables/compare.md", "tables/compare.html"]
GALLERY = ["figures/index.md", "figures/index.html"]
FIGURE_SUMS = "figures/SHA256SUMS"
TABLE_SUMS = "tables/SHA256SUMS"


def feeds_compare(key):
    """Paper-vs-reproduced twins feed the comparison page; Table I enters by its long form instead of its twin."""
    if key.startswith("table01_"):
        return key == "table01_ar_orders_csv"
    return key.endswith("_vs_paper_csv")


TWINS = [f for p in TABLES.values() for k, f in p.outputs(config).items() if feeds_compare(k)]
#: twin path -> its table rule and data kind; table rule -> [(figure rule, label)] drawn from it (comparison page)
TWIN_TABLES = {f: {"table": n, "data": p.data_kind(config)} for n, p in TABLES.items() for k, f in p.outputs(config).items() if feeds_compare(k)}
FIGURES_OF_TABLE = {t: [[n, f"{PAPERS[p.paper]} {p.number or n}"] for n, p in FIGURES.items() if t in p.tables] for t in TABLES}


def report_section(product):
    return product.section + (" (SURROGATE data)" if product.is_surrogate(config) else "")


# --- publication bundle
from scintrack import __version__ as SCINTRACK_VERSION
from scintrack.archive.build import version_of
from scintrack.io import git_state

GIT = git_state(Path(workflow.basedir))
ARCHIVE_VERSION = version_of(SCINTRACK_VERSION, GIT)
ARCHIVE_FILE = f"archive/{config['archive']['name']}-{ARCHIVE_VERSION}.tar.gz"
ALL_RESULTS = sorted(P.results(config))


# --- threads and resources (mem_mb, runtime in minutes) of the computing rules,
# measured on a full run (scintrack.pipeline.resources); changing them reruns nothing
from scintrack.pipeline import resources as RES
