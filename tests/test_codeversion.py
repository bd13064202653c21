"""Code versions from the normalised AST of the import closure."""

from __future__ import annotations

import shutil

import pytest
from conftest import REPO

from scintrack import codeversion
from scintrack.codeversion import code_version, import_closure, normalised_source

SCRIPTS = REPO / "workflow" / "scripts"


def test_comments_docstrings_and_formatting_do_not_count(tmp_path):
    a, b, c = tmp_path / "a.py", tmp_path / "b.py", tmp_path / "c.py"
    a.write_text('"""Doc."""\nimport math\n\n\ndef f(x):\n    """Square root."""\n    return math.sqrt(x)  # comment\n')
    b.write_text("import math\ndef f( x ):\n    # another comment\n    return math.sqrt(\n        x\n    )\n")
    c.write_text("import math\ndef f(x):\n    return math.sqrt(x) + 0\n")
    assert normalised_source(a) == normalised_source(b)
    assert normalised_source(a) != normalised_source(c)


def test_closure_follows_imports_transitively_and_inside_functions():
    closure = import_closure([SCRIPTS / "trace_ar_models.py"])
    # the script imports experiments.traces, which imports models.ar (fit_ar) and more
    assert "scintrack.experiments.traces" in closure
    assert "scintrack.models.ar" in closure
    assert "scintrack" in closure and "scintrack.experiments" in closure  # packages whose __init__ runs
    # render_table imports the table module only through the product registry
    assert "scintrack.products" in import_closure([SCRIPTS / "render_table.py"])
    # a function-local import counts too (the tables import experiments.metrics inside table07)
    assert "scintrack.experiments.metrics" in import_closure(["scintrack.products.tables.vila_valls_2018"])


def test_unknown_module_is_an_error():
    with pytest.raises(ValueError, match="not a module"):
        import_closure(["scintrack.no_such_module"])


def test_version_changes_with_an_imported_module_and_not_with_a_comment(tmp_path, monkeypatch):
    pkg = tmp_path / "scintrack"
    shutil.copytree(REPO / "src" / "scintrack", pkg, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(codeversion, "ROOT", pkg)
    codeversion.clear_caches()
    script = SCRIPTS / "trace_ar_models.py"
    before = code_version([script])
    ar = pkg / "models" / "ar.py"
    ar.write_text(ar.read_text() + "\n# a comment changes nothing\n")
    codeversion.clear_caches()
    assert code_version([script]) == before
    ar.write_text(ar.read_text() + "\nUNUSED_FOR_THIS_TEST = 1\n")
    codeversion.clear_caches()
    assert code_version([script]) != before
    # an unrelated module (the archive code) is not in this rule's closure
    build = pkg / "archive" / "build.py"
    after = code_version([script])
    build.write_text(build.read_text() + "\nUNUSED = 2\n")
    codeversion.clear_caches()
    assert code_version([script]) == after
