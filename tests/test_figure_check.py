"""The layout check of every figure (scintrack.products.figure_check), the figure records and the gallery.

The check is tested on figures built to break each rule (and on one built to
pass them all); the smoke build's figures must all pass it (each figure rule
records its problems in ``<stem>.json``), and the gallery must show every figure.
"""

from __future__ import annotations

import base64
import json
import re

import numpy as np
import pytest

from scintrack.products import products
from scintrack.products.figure_check import check_figure
from scintrack.products.figures.common import new_figure
from scintrack.products.figures.conventions import (
    NO_LOCK_RMSE_2PI,
    NO_LOCK_RMSE_PI,
    figure_legend,
    legend_outside,
    log_ticks,
    no_lock_level,
    until_lock_lost,
)


def _clean_figure():
    fig, axes = new_figure(2, 1, figsize=(6.4, 5.0))
    t = np.linspace(0.0, 10.0, 500)
    for ax in axes:
        ax.plot(t, np.sin(t), label="one")
        ax.plot(t, np.cos(t), label="two")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("error [rad]")
        ax.set_title("a readable title")
        legend_outside(ax)
    fig.tight_layout()
    return fig


def _rules(problems):
    return {p.split(":")[0] for p in problems}


def test_a_figure_following_the_conventions_passes():
    assert check_figure(_clean_figure()) == []


@pytest.mark.parametrize(
    ("breaker", "rule"),
    [
        (lambda fig, ax: ax.legend(loc="center"), "legend-on-data"),
        (lambda fig, ax: fig.text(0.97, 0.5, "a note that runs off the right edge"), "text-outside"),
        (lambda fig, ax: ax.set_title("a title " * 30), "title-too-wide"),
        (lambda fig, ax: ax.set_yticks([0.0]), "few-ticks"),
        (lambda fig, ax: ax.set_xlabel("time [s]", fontsize=5.5), "small-font"),
    ],
)
def test_each_broken_rule_is_named(breaker, rule):
    fig, ax = new_figure(1, 1, figsize=(6.4, 4.0))
    t = np.linspace(0.0, 10.0, 500)
    ax.plot(t, np.sin(t), label="one")
    ax.plot(t, np.cos(t), label="two")
    ax.set_xlabel("time [s]")
    breaker(fig, ax)
    assert rule in _rules(check_figure(fig))


def test_a_short_reference_line_under_a_legend_counts_by_its_length():
    fig, ax = new_figure(1, 1, figsize=(6.4, 4.0))
    ax.plot([0, 1], [0, 1], color="k")
    ax.axhline(0.97, label="no lock")  # two points; the legend sits on its left part
    ax.legend(loc="upper left")
    assert "legend-on-data" in _rules(check_figure(fig))


def test_log_ticks_label_a_narrow_decade():
    fig, ax = new_figure(1, 1, figsize=(6.4, 4.0))
    ax.semilogy([0, 1], [0.55, 1.7])
    ax.set_ylim(0.5, 1.8)
    log_ticks(ax)
    fig.draw_without_rendering()
    labels = [lab.get_text() for loc, lab in zip(ax.yaxis.get_majorticklocs(), ax.yaxis.get_majorticklabels()) if 0.5 <= loc <= 1.8]
    assert {"0.6", "0.8", "1", "1.2", "1.4", "1.6"} <= set(labels)


def test_no_lock_levels_are_the_uniform_rmse_of_each_wrapping():
    rng = np.random.default_rng(1)
    u = rng.uniform(-np.pi, np.pi, 400_000)
    assert np.sqrt(np.mean(u**2)) == pytest.approx(NO_LOCK_RMSE_2PI, rel=3e-3)
    assert np.sqrt(np.mean((u / 2) ** 2)) == pytest.approx(NO_LOCK_RMSE_PI, rel=3e-3)
    fig, ax = new_figure(1, 1, figsize=(6.4, 4.0))
    ax.plot([0, 1], [0.2, 0.4])
    no_lock_level(ax)
    assert any("1.81 rad" in t.get_text() for t in ax.texts)


def test_until_lock_lost_cuts_a_runaway_and_keeps_a_relocked_slip():
    t = np.arange(10.0)
    runaway = np.array([0.1, -0.2, 0.3, 4.0, 10.0, 50.0, 1e3, 1e5, 1e7, 1e8])
    cut, lost = until_lock_lost(t, runaway, np.pi)
    assert lost == 3.0 and np.all(np.isnan(cut[3:])) and np.array_equal(cut[:3], runaway[:3])
    slip = np.array([0.1, 4.0, 0.2, 0.1, -0.1, 0.0, 0.1, 0.2, 0.0, 0.1])
    same, never = until_lock_lost(t, slip, np.pi)
    assert never is None and np.array_equal(same, slip)


def test_a_figure_legend_below_the_panels_leaves_the_data_free():
    fig, axes = new_figure(2, 1, figsize=(6.4, 5.0))
    t = np.linspace(0, 1, 100)
    lines = [axes[0].plot(t, t * k, label=f"curve {k}")[0] for k in range(5)]
    for ax in axes:
        ax.set_xlabel("x [s]")
    fig.tight_layout()
    figure_legend(fig, lines, [ln.get_label() for ln in lines], ncol=3)
    assert check_figure(fig) == []


@pytest.mark.pipeline
def test_every_smoke_figure_passes_the_layout_check(smoke_run):
    records = sorted((smoke_run / "figures").glob("*/*.json"))
    assert len(records) == len(products("figure"))
    failing = []
    for path in records:
        rec = json.loads(path.read_text())
        failing += [f"{rec['name']} ({path.name}): {p}" for p in rec["layout_problems"]]
    assert not failing, "\n".join(failing)


@pytest.mark.pipeline
def test_gallery_shows_every_figure_with_a_verdict_and_its_data(smoke_run):
    page = (smoke_run / "figures" / "index.html").read_text()
    md = (smoke_run / "figures" / "index.md").read_text()
    records = [json.loads(p.read_text()) for p in sorted((smoke_run / "figures").glob("*/*.json"))]
    images = re.findall(r"src='data:image/png;base64,([^']+)'", page)
    assert len(images) == len(records)
    assert all(base64.b64decode(b)[:8] == b"\x89PNG\r\n\x1a\n" for b in images)
    for rec in records:
        assert f"id='{rec['name']}'" in page and rec["png"] in md
        assert rec["verdict"]["status"] in {"reproduced", "differs", "not reproduced", "no paper figure"}
        if rec["number"]:
            assert rec["claim"], f"{rec['name']}: a paper figure without the paper's claim"
            assert rec["verdict"]["text"], f"{rec['name']}: a verdict without its number"
    assert "http://" not in page and "https://" not in page  # nothing fetched from a network
