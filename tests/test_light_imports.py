"""Snakemake builds the DAG without the numerical stack.

Every ``snakemake`` invocation parses the Snakefile and the rule files and
calls the params, input and resource functions of every job; importing
numba, xarray, scipy, statsmodels, matplotlib or netCDF4 there cost 0.5-0.9 s
of CPU per invocation before any job ran.  These tests run a fresh
interpreter, so a module that is already imported by another test cannot hide
an import.  (numpy and pandas are not checked: Snakemake itself imports them,
through the SLURM executor plugin it loads at start-up.)
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap

import pytest
from conftest import REPO

HEAVY = ("numba", "xarray", "scipy", "statsmodels", "matplotlib", "netCDF4")
REPORT = f"""
import json, sys
print(json.dumps(sorted(m for m in sys.modules if m.split(".")[0] in {HEAVY!r})))
"""


def smk_import_statements() -> list[str]:
    """The import statements of the Snakefile and of every ``workflow/rules/*.smk`` file, dedented
    (those inside ``onstart:`` or a function included: they run at start-up too)."""
    statements = []
    for path in [REPO / "Snakefile", *sorted((REPO / "workflow" / "rules").glob("*.smk"))]:
        lines = path.read_text(encoding="utf-8").splitlines()
        i = 0
        while i < len(lines):
            line = lines[i].strip()
            if re.match(r"(import|from)\s+[\w.]+", line):
                while line.count("(") > line.count(")"):  # a parenthesised import over several lines
                    i += 1
                    line += " " + lines[i].strip()
                statements.append(line)
            i += 1
    return statements


def heavy_modules_after(code: str, env: dict[str, str] | None = None) -> list[str]:
    proc = subprocess.run([sys.executable, "-c", code + REPORT], cwd=REPO, capture_output=True, text=True, timeout=300,
                          env=env or dict(os.environ))
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_the_workflow_imports_no_numerical_stack():
    statements = smk_import_statements()
    assert any("scintrack.pipeline import params" in s for s in statements)  # the parser found the rule files' imports
    code = "import sys\nsys.path.insert(0, 'src')\n" + "\n".join(statements) + "\n"
    assert heavy_modules_after(code) == []


DAG_TIME_CALLS = textwrap.dedent("""
    import sys
    from pathlib import Path
    sys.path.insert(0, "src")
    from scintrack.archive.build import version_of
    from scintrack.config import check_consistency, load_config
    from scintrack.io import git_state
    from scintrack.pipeline import params as P, paths, resources as RES
    from scintrack.products import products

    config = load_config([Path("config/config.yaml")])
    check_consistency(config)
    P.results(config)
    for s4 in config["ar_training"]["s4"]:
        paths.training_path(config, s4), P.training(config, s4), P.ar_fit(config, s4), P.ar_fit(config, s4, "wrapped")
    for event in config["real_traces"]["events"]:
        paths.trace_path(config, event), P.trace_input(config, event)
    for name in config["susi_2014"]["traces"]:
        P.susi_trace(config, name)
    for scenario in P.susi_scenarios(config):
        paths.scenario_trace_path(config, scenario)
    paths.gps_dataset_path(config), paths.gps_iq_paths(config), P.gps_dataset(config), P.gps_iq(config)
    for name in config["experiments"]:
        RES.experiment_mem_mb(config, name), RES.experiment_runtime(config, name)
    RES.zhao_channel_mem_mb(config), RES.zhao_channel_runtime(config)
    for product in products().values():
        product.outputs(config), product.inputs(config), product.kwargs(config)
    version_of("0", git_state(Path(".")))
""")


def test_building_the_dag_imports_no_numerical_stack(tmp_path):
    """The calls ``workflow/rules/*.smk`` make while Snakemake builds the DAG, on the shipped config.

    The config check and the tracking keys of the tracker specs import the
    tracker modules (numba) and xarray; they are remembered per code version
    (:func:`scintrack.codeversion.remembered`), so only the first run after an
    edit pays for them: the second run here must import none of them.
    """
    env = dict(os.environ, SCINTRACK_CODE_CACHE=str(tmp_path / "code-cache.json"))
    first = heavy_modules_after(DAG_TIME_CALLS, env)
    assert "numba" in first  # the first run computed the config check with the tracker modules
    assert heavy_modules_after(DAG_TIME_CALLS, env) == []


def test_remembered_keeps_passes_only_and_follows_code_and_argument(tmp_path, monkeypatch):
    from scintrack import codeversion

    monkeypatch.setenv("SCINTRACK_CODE_CACHE", str(tmp_path / "cache.json"))
    codeversion.clear_caches()
    codeversion.clear_disk_cache_memory()
    calls = []

    def compute(value):
        def run():
            calls.append(value)
            if value == "bad":
                raise ValueError("refused")
            return [value]

        return run

    try:
        assert codeversion.remembered("scintrack.progress", "t", {"a": 1}, compute(1)) == [1]
        codeversion.clear_disk_cache_memory()  # a new process: read from the file
        assert codeversion.remembered("scintrack.progress", "t", {"a": 1}, compute(2)) == [1] and calls == [1]
        assert codeversion.remembered("scintrack.errors", "t", {"a": 1}, compute(3)) == [3]  # other code: a miss
        assert codeversion.remembered("scintrack.progress", "t", {"a": 2}, compute(4)) == [4]  # other argument: a miss
        for _ in range(2):  # an error is never remembered
            with pytest.raises(ValueError, match="refused"):
                codeversion.remembered("scintrack.progress", "t", {"a": 3}, compute("bad"))
        for value in (5, 6):  # keep() false: computed every time
            assert codeversion.remembered("scintrack.progress", "t", {"a": 4}, compute(value), keep=lambda: False) == [value]
        assert codeversion.remembered("scintrack.progress", "t", {"a": object()}, compute(7)) == [7]  # not JSON: computed
        assert calls == [1, 3, 4, "bad", "bad", 5, 6, 7]
    finally:
        codeversion.clear_caches()
        codeversion.clear_disk_cache_memory()


RENDER_IMPORTS = textwrap.dedent("""
    import importlib, sys
    sys.path.insert(0, "src")
    from scintrack import runlog
    from scintrack.experiments.guards import divergence_note
    from scintrack.products.figures.common import add_footer, save_figure
    from scintrack.io import open_dataset
    from scintrack.products import PRODUCT_MODULES, products
    from scintrack.products.tables.common import write_table
    for module in PRODUCT_MODULES:
        importlib.import_module(module)
    products()
""")


def test_figure_and_table_jobs_import_no_numba_statsmodels_or_scipy_stats():
    """What the render scripts and every figure/table module import at start: none of the compute stack
    (a render job reads results; numba's and statsmodels' imports alone cost more than most renders)."""
    code = RENDER_IMPORTS + "\nprint(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in ('numba', 'statsmodels') or m.startswith('scipy.stats'))))\n"
    proc = subprocess.run([sys.executable, "-c", "import json\n" + code], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert json.loads(proc.stdout.strip().splitlines()[-1]) == []
