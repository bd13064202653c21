"""docs/pipeline.md lists every rule of the workflow (the table of scintrack.products.rules_table), and is current."""

from __future__ import annotations

import re
import subprocess

from conftest import REPO, SNAKEMAKE, snakemake_env

from scintrack.products.rules_table import current_block, literal_rules, render


def test_docs_hold_the_current_rules_table():
    doc = (REPO / "docs" / "pipeline.md").read_text(encoding="utf-8")
    assert current_block(doc) == render(REPO), "docs/pipeline.md is out of date: run `python -m scintrack rules-doc --write`"


def test_the_table_names_every_rule_snakemake_knows():
    proc = subprocess.run([SNAKEMAKE, "--list-rules", "-s", str(REPO / "Snakefile"), "--directory", str(REPO)], capture_output=True, text=True,
                          timeout=300, env=snakemake_env(), cwd=REPO)
    assert proc.returncode == 0, proc.stderr[-2000:]
    known = {line.split()[0] for line in proc.stdout.splitlines() if re.match(r"^\w+( |$)", line)}  # "name (docstring)"
    assert len(known) > 50 and {"all", "tracking_cycle_slips", "fig07", "table03"} <= known
    table = render(REPO)
    listed = set(re.findall(r"^\| `(\w+)` \|", table, re.M))
    assert known <= listed, sorted(known - listed)
    assert listed - known <= {"fetch_trace", "trace_dataset"}, sorted(listed - known)  # defined only when real traces are configured


def test_literal_rules_parse_name_doc_and_script(tmp_path):
    (tmp_path / "a.smk").write_text('rule one:\n    """Makes one."""\n    output:\n        "x"\n    script:\n        "../scripts/one.py"\n\n\n'
                                    'if True:\n\n    rule two:\n        """Makes two."""\n        script:\n            "../scripts/two.py"\n')
    assert literal_rules(tmp_path) == [("one", "workflow/rules/a.smk", "Makes one.", "workflow/scripts/one.py"),
                                       ("two", "workflow/rules/a.smk", "Makes two.", "workflow/scripts/two.py")]
