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
