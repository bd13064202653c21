"""The publication bundle: byte-reproducible tarball, tamper detection, refusals, comparison page."""

from __future__ import annotations

import json
import tarfile

import pandas as pd
import pytest

from scintrack.__main__ import main as cli
from scintrack.archive.build import ArchiveRefused, check_tree, version_of
from scintrack.archive.compare import DATA_LABELS, collect, headline, render, summary
from scintrack.archive.metadata import ro_crate
from scintrack.archive.tarball import MTIME, SUMS, sums_text, write_tarball
from scintrack.archive.verify import verify
from scintrack.io import sha256_file


def _members():
    m = {"figures/a.png": b"\x89PNG fake", "tables/t.md": b"| a |\n", "results/r.nc": b"CDF data"}
    m[SUMS] = sums_text(m).encode()
    return m


def test_tarball_is_byte_reproducible_and_normalised(tmp_path):
    a = write_tarball(_members(), tmp_path / "one.tar.gz", root="bundle-1")
    b = write_tarball(dict(reversed(list(_members().items()))), tmp_path / "two.tar.gz", root="bundle-1")
    assert a == b == sha256_file(tmp_path / "one.tar.gz")
    with tarfile.open(tmp_path / "one.tar.gz") as tar:
        infos = tar.getmembers()
    assert [i.name for i in infos] == sorted(i.name for i in infos)
    assert all(i.mtime == MTIME and i.uid == 0 and i.gid == 0 and i.uname == "" and i.mode == 0o644 for i in infos)
    assert (tmp_path / "one.tar.gz").read_bytes()[4:8] == b"\x00\x00\x00\x00"  # gzip header mtime 0


def test_verify_reports_each_tampering_precisely(tmp_path):
    write_tarball(_members(), tmp_path / "b.tar.gz", root="b")
    assert verify(tmp_path / "b.tar.gz") == []
    with tarfile.open(tmp_path / "b.tar.gz") as tar:
        tar.extractall(tmp_path / "x", filter="data")
    root = tmp_path / "x" / "b"
    assert verify(root) == []
    png = root / "figures" / "a.png"
    png.write_bytes(png.read_bytes()[:-1] + b"!")  # one byte changed
    (root / "tables" / "t.md").unlink()
    (root / "extra.txt").write_text("not listed")
    problems = verify(root)
    assert len(problems) == 3
    assert problems[0].startswith("CHANGED figures/a.png")
    assert problems[1] == "MISSING tables/t.md"
    assert problems[2].startswith("EXTRA extra.txt")
    assert cli(["verify", str(root)]) == 1
    assert cli(["verify", str(tmp_path / "b.tar.gz")]) == 0
    assert cli(["verify", str(tmp_path / "nope.tar.gz")]) == 2


def test_archive_refuses_dirty_or_inconsistent_trees(tmp_path):
    with pytest.raises(ArchiveRefused, match="uncommitted changes.*allow-dirty"):
        check_tree({"git_dirty": True}, False, [])
    check_tree({"git_dirty": True}, True, [])
    (tmp_path / "f.png").write_bytes(b"x")
    sums = tmp_path / "SHA256SUMS"
    sums.write_text(f"{sha256_file(tmp_path / 'f.png')}  f.png\n")
    check_tree({"git_dirty": False}, False, [sums])
    (tmp_path / "f.png").write_bytes(b"y")
    with pytest.raises(ArchiveRefused, match="does not match"):
        check_tree({"git_dirty": False}, False, [sums])
    (tmp_path / "f.png").unlink()
    with pytest.raises(ArchiveRefused, match="incomplete"):
        check_tree({"git_dirty": False}, False, [sums])
    assert version_of("0.1.0", {"git_commit": "abcdef0123456789", "git_dirty": True}) == "0.1.0+gabcdef0123.dirty"


def test_compare_page_counts_cells(tmp_path):
    folder = tmp_path / "vila_valls_2018"
    folder.mkdir()
    pd.DataFrame(
        [
            {"row": "a", "column": "x", "paper": 1.0, "reproduced": 1.05, "ci95_lo": 0.9, "ci95_hi": 1.1, "ratio_reproduced_over_paper": 1.05, "paper_within_ci95": True},
            {"row": "b", "column": "x", "paper": 1.0, "reproduced": 1.2, "ci95_lo": 1.15, "ci95_hi": 1.25, "ratio_reproduced_over_paper": 1.2, "paper_within_ci95": False},
            {"row": "c", "column": "x", "paper": 1.0, "reproduced": 3.0, "ci95_lo": 2.9, "ci95_hi": 3.1, "ratio_reproduced_over_paper": 3.0, "paper_within_ci95": False},
            {"row": "d", "column": "x", "paper": float("nan"), "reproduced": 3.0, "ci95_lo": 2.9, "ci95_hi": 3.1, "ratio_reproduced_over_paper": float("nan"), "paper_within_ci95": False},
        ]
    ).to_csv(folder / "table09_x_vs_paper.csv", index=False)
    df = collect([folder / "table09_x_vs_paper.csv"])
    assert list(df["verdict"]) == ["within 95% CI", "within 25%", "beyond", "no paper value"]
    assert summary(df).startswith("3 cells with a paper value: 1 within our 95% interval, 1 more within 25%, 1 beyond")
    md, page = render(df)
    assert "table09_x" in md and page.startswith("<!DOCTYPE html>") and "Vil" in page


def test_compare_page_counts_each_data_kind_apart_and_links_tables_to_figures(tmp_path):
    folder = tmp_path / "vila_valls_2018"
    folder.mkdir()
    cell = {"column": "x", "paper": 1.0, "ci95_lo": 0.9, "ci95_hi": 1.1}
    pd.DataFrame([{**cell, "row": "a", "reproduced": 1.0, "ratio_reproduced_over_paper": 1.0, "paper_within_ci95": True}]).to_csv(
        folder / "table03_a_vs_paper.csv", index=False)
    (folder / "table03_a_vs_paper.md").write_text("# Table III: paper vs reproduced\n")
    pd.DataFrame([{**cell, "row": r, "reproduced": 5.0, "ratio_reproduced_over_paper": 5.0, "paper_within_ci95": False} for r in "bc"]).to_csv(
        folder / "table06_b_surrogate_vs_paper.csv", index=False)
    tables = {(folder / "table03_a_vs_paper.csv").as_posix(): {"table": "table03", "data": "synthetic CSM"},
              (folder / "table06_b_surrogate_vs_paper.csv").as_posix(): {"table": "table06", "data": "surrogate"}}
    df = collect(tables, tables)
    md, page = render(df, {"table03": [("fig07", "Fig. 7")]})
    lines = dict(headline(df))
    assert lines[DATA_LABELS["synthetic CSM"]].startswith("1 cells with a paper value: 1 within")
    assert lines[DATA_LABELS["surrogate"]].startswith("2 cells with a paper value: 0 within our 95% interval, 0 more within 25%, 2 beyond")
    assert "Table III (table03_a)" in md and "id='table03'" in page and "../figures/index.html#fig07" in page
    assert "our 95% interval" in page and "ratio_reproduced_over_paper" not in page


def test_ro_crate_lists_every_file_with_its_hash():
    crate = json.loads(ro_crate(_members(), name="b", version="1", commit="c"))
    ids = {e["@id"]: e for e in crate["@graph"]}
    assert "https://w3id.org/ro/crate/1.1" in json.dumps(ids["ro-crate-metadata.json"]["conformsTo"])
    assert ids["#run"]["@type"] == "CreateAction"
    assert ids["figures/a.png"]["sha256"] == __import__("hashlib").sha256(b"\x89PNG fake").hexdigest()
