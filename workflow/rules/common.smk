# Shared setup: config validation, dataset versions and output paths.

import sys
from pathlib import Path

from snakemake.exceptions import WorkflowError
from snakemake.utils import validate

sys.path.insert(0, str(Path(workflow.basedir) / "src"))

from scintrack.config import ConfigError, check_consistency, format_validation_error
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
}
VV_TABLES += [f"{VV_TAB}/{stem}.{ext}" for stems in VV_TABLE_STEMS.values() for stem in stems for ext in ("csv", "md")]


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
}
# table rule name -> (function in scintrack.tables.vila_valls_2018, inputs)
VV_TABLE_SPECS = {
    "table02": ("table02", {"equivalence": exp_result("case1_equivalence", "s4_0.8_tau0_0.2")}),
    "table03": ("table03", _inputs("case2_steady_state")),
    "table04": ("table04", _inputs("case3_mismatch")),
    "table07": ("table07", _inputs("cycle_slips")),
    "tableS1": ("table_s1", _inputs("iso_ar_world")),
    "tableS2": ("table_s2", _inputs("iso_q_sensitivity")),
}
