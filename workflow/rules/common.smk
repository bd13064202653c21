# Shared setup: config validation, dataset versions and output paths.

import sys
from pathlib import Path

from snakemake.exceptions import WorkflowError
from snakemake.utils import validate

sys.path.insert(0, str(Path(workflow.basedir) / "src"))

from scintrack.config import ConfigError, check_consistency, format_validation_error
from scintrack.data.registry import expected_sha256
from scintrack.data.surrogate import surrogate_params, surrogate_version
from scintrack.data.synthetic import csm_training_name, csm_training_params, csm_training_version


def _validate_config():
    try:
        validate(config, "../schemas/config.schema.yaml")
        check_consistency(config)
    except WorkflowError as exc:
        # snakemake.utils.validate raises WorkflowError from inside the
        # handler of the jsonschema ValidationError, which is its context.
        cause = exc.__cause__ or exc.__context__
        cause = cause if hasattr(cause, "absolute_path") else None
        if cause is None:
            raise
        raise WorkflowError(format_validation_error(cause)) from None
    except ConfigError as exc:
        raise WorkflowError(str(exc)) from None


_validate_config()


def code_hash(*parts):
    """sha256 of the library sources a rule depends on (a param, so editing
    them triggers Snakemake's params rerun; results stay cached otherwise)."""
    import hashlib

    h = hashlib.sha256()
    root = Path(workflow.basedir) / "src" / "scintrack"
    for part in parts:
        target = root / part
        for f in sorted(target.rglob("*.py")) if target.is_dir() else [target]:
            h.update(f.relative_to(root).as_posix().encode())
            h.update(f.read_bytes())
    return h.hexdigest()[:16]


CODE_AR = code_hash("models")
CODE_TRACKING = code_hash("signals", "trackers", "estimators", "experiments", "seeding.py", "io.py")
CODE_FIGURES = code_hash("figures")
CODE_TABLES = code_hash("tables", "figures/vila_valls_2018.py", "experiments/metrics.py")
CODE_SURROGATE = code_hash("signals/phase_screen.py", "data/surrogate.py")
CODE_TRACES = code_hash("data/traces.py")


# --- Sec. VI-E: real traces, or the synthetic surrogate when none are configured
RT = config["real_traces"]
RT_SOURCE = "real" if RT["sources"] else "surrogate"
RT_SUFFIX = "" if RT_SOURCE == "real" else "_surrogate"
if RT_SOURCE == "surrogate":
    print("real_traces: the JRC traces are not configured (real_traces.sources is empty); Sec. VI-E outputs use the synthetic SURROGATE and say so", file=sys.stderr)


def repo_path(path):
    """A path from the config: absolute, or relative to the working directory if it exists there, else to the repository."""
    p = Path(path)
    if p.is_absolute() or p.exists():
        return str(p)
    return str(Path(workflow.basedir) / p)


REGISTRY = repo_path(RT["registry"])


def registry_name(event):
    return f"jrc_hanoi_{event}"


def raw_trace_path(event):
    src = RT["sources"][event]
    fmt_ = src.get("format") or Path(str(src.get("url") or src.get("path")).split("?")[0]).suffix.lstrip(".").lower()
    if fmt_ not in ("nc", "mat", "npz", "csv"):
        raise WorkflowError(f"real_traces.sources.{event}: cannot tell the format from {src}; add format: nc|mat|npz|csv")
    return f"data/raw/jrc_hanoi/{event}.{fmt_}"


def trace_path(event):
    """The canonical (validated) trace file of an event, real or surrogate."""
    if RT_SOURCE == "real":
        return f"data/traces/real/{event}.nc"
    params = surrogate_params(config, event)
    return f"data/synthetic/surrogate_{event}/{surrogate_version(params)}.nc"


TRACE_FILES = {e: trace_path(e) for e in RT["events"]}
RT_RES = f"results/real_traces/{RT_SOURCE}"
RT_MODELS = {e: f"{RT_RES}/ar_models/{e}.nc" for e in RT["events"]}
RT_DIAG = f"{RT_RES}/diagnostics.nc"
RT_STATIC = {e: f"{RT_RES}/static/{e}.nc" for e in RT["events"]}
RT_DYNAMICS = {e: f"{RT_RES}/dynamics/{e}.nc" for e in RT["events"]}
_RT = "Sec. VI-E: real traces" + (" (SURROGATE data)" if RT_SOURCE == "surrogate" else "")



def fmt(x):
    """Canonical text of a grid value in file names (0.9, not 0.90)."""
    return f"{float(x):g}"


TRAIN_S4 = [fmt(s) for s in config["ar_training"]["s4"]]


def training_path(s4):
    params = csm_training_params(config, float(s4))
    return f"data/synthetic/{csm_training_name(float(s4))}/{csm_training_version(params)}.nc"


TRAINING_SETS = [training_path(s) for s in TRAIN_S4]
DATASET_MANIFEST = "data/manifest.json"
AR_LUT = "results/ar_models/ar_lut.nc"
VV_DIAGNOSTICS = "results/vila_valls_2018/ar_diagnostics.nc"

VV_FIG = "figures/vila_valls_2018"
VV_TAB = "tables/vila_valls_2018"
VV_FIGURE_STEMS = {
    "fig01": "fig01_csm_amplitude_psd_ar",
    "fig02": "fig02_csm_amplitude_pacf",
    "fig03": "fig03_csm_phase_psd_ar",
    "fig04": "fig04_csm_phase_pacf",
    "fig06": "fig06_rmse_free_and_ssm_equivalence",
    "fig07": "fig07_rmse_severe_moderate",
    "fig08": "fig08_rmse_ar_mismatch",
    "fig09": "fig09_rmse_time_varying",
    "fig16": "fig16_cycle_slip_examples",
}
VV_FIGURE_STEMS.update(
    {
        "fig10": f"fig10_trace_amplitude_bands{RT_SUFFIX}",
        "fig11": f"fig11_static_scintillation_tracking{RT_SUFFIX}",
        "fig12": f"fig12_trace_s4{RT_SUFFIX}",
        "fig13": f"fig13_trace_amplitude_pacf{RT_SUFFIX}",
        "fig14": f"fig14_trace_phase_pacf{RT_SUFFIX}",
        "fig15": f"fig15_trace_phase_error{RT_SUFFIX}",
    }
)
VV_FIGURES = [f"{VV_FIG}/{stem}.{ext}" for stem in VV_FIGURE_STEMS.values() for ext in ("pdf", "png")]
VV_TABLES = [
    f"{VV_TAB}/table01_ar_orders.csv",
    f"{VV_TAB}/table01_ar_orders.md",
    f"{VV_TAB}/table01_ar_orders_vs_paper.csv",
    f"{VV_TAB}/table01_ar_orders_vs_paper.md",
    f"{VV_TAB}/table01s_pacf_order_vs_length.csv",
    f"{VV_TAB}/table01s_pacf_order_vs_length.md",
]

VV_TABLE_STEMS = {
    "table02": ["table02_ssm_equivalence"],
    "table03": ["table03_steady_state_rmse", "table03_steady_state_rmse_long", "table03_steady_state_rmse_vs_paper"],
    "table04": ["table04_ar_mismatch", "table04_ar_mismatch_vs_paper"],
    "table07": ["table07_cycle_slips", "table07_cycle_slips_long", "table07_cycle_slips_vs_paper"],
    "tableS1": ["tableS1_ar_world"],
    "tableS2": ["tableS2_q_sensitivity"],
    "tableS4": ["tableS4_mirror_fold"],
    "table05": ["table05_static_tracking", "table05_static_tracking_vs_paper"],
    "table06": ["table06_trace_rmse", "table06_trace_rmse_vs_paper"],
    "table08": ["table08_trace_cycle_slips", "table08_trace_cycle_slips_vs_paper"],
    "tableS3": ["tableS3_trace_data"],
}
# file name of a table stem (Sec. VI-E tables carry the source suffix)
VV_TABLE_FILE = {stem: stem for stems in VV_TABLE_STEMS.values() for stem in stems}
for _t in ("table05", "table06", "table08", "tableS3"):
    for _stem in VV_TABLE_STEMS[_t]:
        VV_TABLE_FILE[_stem] = _stem + RT_SUFFIX
VV_TABLES += [f"{VV_TAB}/{VV_TABLE_FILE[stem]}.{ext}" for stems in VV_TABLE_STEMS.values() for stem in stems for ext in ("csv", "md")]


def exp_result(exp, scenario):
    return f"results/experiments/{exp}/{scenario}.nc"


def shard_trials(exp, shard):
    """Contiguous block of trial indices of one shard."""
    spec = config["experiments"][exp]
    n, k = int(spec["trials"]), int(spec["shards"])
    edges = [round(i * n / k) for i in range(k + 1)]
    return list(range(edges[shard], edges[shard + 1]))


def _inputs(exp):
    return {sc: exp_result(exp, sc) for sc in config["experiments"][exp]["scenarios"]}


VV_PACF_LAGS = config["figures"]["vila_valls_2018"]["pacf_lags_shown"]
_AR = "Sec. III: AR models"
_CSM = "Sec. VI: tracking on CSM data"
# figure name -> (inputs passed to the function in order, keyword arguments, report subcategory)
VV_FIGURE_SPECS = {
    "fig01": ({"diag": VV_DIAGNOSTICS}, {}, _AR),
    "fig02": ({"diag": VV_DIAGNOSTICS}, {"lags_shown": VV_PACF_LAGS}, _AR),
    "fig03": ({"diag": VV_DIAGNOSTICS}, {}, _AR),
    "fig04": ({"diag": VV_DIAGNOSTICS}, {"lags_shown": VV_PACF_LAGS}, _AR),
    "fig06": ({"free": exp_result("case1_free", "free"), "equivalence": exp_result("case1_equivalence", "s4_0.8_tau0_0.2")}, {}, _CSM),
    "fig07": ({"severe": exp_result("case2_steady_state", "s4_0.9_tau0_0.1"), "moderate": exp_result("case2_steady_state", "s4_0.5_tau0_0.4")}, {}, _CSM),
    "fig08": ({"mismatch": exp_result("case3_mismatch", "s4_0.8_tau0_0.2")}, {}, _CSM),
    "fig09": ({"s2m": exp_result("case4_transitions", "severe_to_moderate"), "m2s": exp_result("case4_transitions", "moderate_to_severe")}, {}, _CSM),
    "fig16": ({"c1": exp_result("cycle_slips", "slips_case1"), "c2": exp_result("cycle_slips", "slips_case2"), "c3": exp_result("cycle_slips", "slips_case3")}, {}, _CSM),
    "fig10": ({"trace": TRACE_FILES[RT["fig10"]["event"]]}, {"start_s": RT["fig10"]["start_s"], "length_s": RT["fig10"]["length_s"]}, _RT),
    "fig11": ({"static": RT_STATIC[RT["fig11"]["event"]]}, {"band": RT["fig11"]["band"]}, _RT),
    "fig12": ({"diag": RT_DIAG}, {}, _RT),
    "fig13": ({"diag": RT_DIAG}, {"component": "amplitude"}, _RT),
    "fig14": ({"diag": RT_DIAG}, {"component": "phase"}, _RT),
    "fig15": ({f"{e}_{b}": RT_DYNAMICS[e] for e, b in RT["fig15"]}, {"cases": [list(c) for c in RT["fig15"]]}, _RT),
}
# figure / table -> module holding its function (Sec. VI-E has its own)
_TRACE_ITEMS = ("fig10", "fig11", "fig12", "fig13", "fig14", "fig15", "table05", "table06", "table08", "tableS3")
VV_MODULE = {k: ("scintrack.figures.vila_valls_2018_traces" if k.startswith("fig") else "scintrack.tables.vila_valls_2018_traces") for k in _TRACE_ITEMS}
# table rule name -> (function in scintrack.tables.vila_valls_2018, inputs)
VV_TABLE_SPECS = {
    "table02": ("table02", {"equivalence": exp_result("case1_equivalence", "s4_0.8_tau0_0.2")}),
    "table03": ("table03", _inputs("case2_steady_state")),
    "table04": ("table04", _inputs("case3_mismatch")),
    "table07": ("table07", _inputs("cycle_slips")),
    "tableS1": ("table_s1", _inputs("iso_ar_world")),
    "tableS2": ("table_s2", _inputs("iso_q_sensitivity")),
    "tableS4": ("table_s4", _inputs("iso_mirror_fold")),
    "table05": ("table05", RT_STATIC),
    "table06": ("table06", RT_DYNAMICS),
    "table08": ("table08", RT_DYNAMICS),
    "tableS3": ("table_s3", TRACE_FILES),
}


# --- publication bundle
from scintrack import __version__ as SCINTRACK_VERSION
from scintrack.archive.build import version_of
from scintrack.io import git_state

GIT = git_state(Path(workflow.basedir))
ARCHIVE_VERSION = version_of(SCINTRACK_VERSION, GIT)
ARCHIVE_FILE = f"archive/{config['archive']['name']}-{ARCHIVE_VERSION}.tar.gz"
COMPARE_PAGE = ["tables/compare.md", "tables/compare.html"]
VV_TWINS = [t for t in VV_TABLES if "_vs_paper" in t and t.endswith(".csv") and "table01_" not in t] + [f"{VV_TAB}/table01_ar_orders.csv"]
ALL_RESULTS = sorted(
    {AR_LUT, VV_DIAGNOSTICS, RT_DIAG, *RT_MODELS.values(), *RT_STATIC.values(), *RT_DYNAMICS.values()}
    | {exp_result(e, s) for e, spec in config["experiments"].items() for s in spec["scenarios"]}
)
