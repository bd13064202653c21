"""One page that reads as a verdict: every reproduced table cell beside the paper's value.

Reads the ``*_vs_paper.csv`` twins and gives each cell a verdict: the
paper's value lies inside our 95% interval, or within 25% of ours, or
beyond; or the paper has no value for it.  A cell without an interval (NaN
bounds: fewer than two trials) shows the words of
:data:`~scintrack.products.tables.common.NO_INTERVAL` in place of one, is
never "within 95% CI", and the summary line counts such cells, whose verdict
rests on the 25% ratio alone.  Table I (AR orders) enters from
its long form: the paper's order against our modal order, with the range of
orders over all fits in place of an interval.

Counts are split by the data a table is drawn from, because agreement means
different things for each: **synthetic as in the paper** (CSM data generated
by the same algorithm as the paper's), **synthetic SKYDEL-like** (our
stand-in for the paper's SKYDEL simulation), **surrogate** (a synthetic
stand-in for real recordings: no agreement is expected, only shapes and
orderings) and **real**.  The page has a headline per data kind, a contents
list with one verdict line per table, and per table its cells (readers'
column names) and links to the figures drawn from it on the gallery page.
Written as Markdown and as a standalone HTML page (no script, no network).
"""

from __future__ import annotations

import html
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from ..products.tables.common import NO_INTERVAL

PAPERS = {
    "vila_valls_2018": "Vilà-Valls et al. 2018, IEEE TAES 54(4), doi:10.1109/TAES.2018.2798480",
    "susi_2014": "Susi, Andreotti & Aquino 2014, KF-based PLLs under scintillation",
    "zhao_jamming": "Zhao, Khanafseh & Pervan, MM Kalman filter through wideband jamming",
}

#: the data kinds as the page names them, in the order of the headline
DATA_LABELS = {
    "synthetic CSM": "synthetic data as in the paper (CSM)",
    "synthetic SKYDEL-like": "synthetic SKYDEL-like data (the paper used SKYDEL)",
    "real": "real recordings",
    "surrogate": "synthetic SURROGATE of real recordings (no agreement expected: shapes and orderings only)",
}

#: readers' names of the columns shown
COLUMNS = {"row": "row", "column": "column", "paper": "paper", "reproduced": "reproduced", "interval": "our 95% interval",
           "ratio": "reproduced / paper", "verdict": "verdict"}


def _verdict(row) -> str:
    if not np.isfinite(row["paper"]):
        return "no paper value"
    if row["paper_within_ci95"]:
        return "within 95% CI"
    if row["paper"] != 0 and abs(row["reproduced"] / row["paper"] - 1) <= 0.25:
        return "within 25%"
    return "beyond"


def _orders_as_cells(df: pd.DataFrame) -> pd.DataFrame:
    """Table I (AR orders): paper order vs our modal order; the 'interval' is the range of orders over all fits."""
    return pd.DataFrame(
        {
            "row": df["region"],
            "column": df["symbol"] + " " + df["criterion"].astype(str),
            "paper": df["paper_order"].astype(float),
            "reproduced": df["modal_order"].astype(float),
            "ci95_lo": df["min_order"].astype(float),
            "ci95_hi": df["max_order"].astype(float),
            "ratio_reproduced_over_paper": df["modal_order"] / df["paper_order"],
            "paper_within_ci95": (df["min_order"] <= df["paper_order"]) & (df["paper_order"] <= df["max_order"]),
        }
    )


def _title(csv: Path, name: str) -> str:
    """The reader's heading of a twin: the title line of the Markdown written beside it by the same job
    (``# Table III: paper vs reproduced`` -> ``Table III``), with its file name."""
    md = csv.with_suffix(".md")
    first = md.read_text().splitlines()[0] if md.exists() else ""
    title = first.removeprefix("# ").split(":")[0].replace(" (reproduced)", "").strip()
    return f"{title} ({name})" if title else name


def collect(paths: Iterable[str | Path], tables: Mapping[str, Mapping[str, str]] | None = None) -> pd.DataFrame:
    """Twin tables (row, column, paper, reproduced, ci95_lo, ci95_hi, ...) plus Table I's long form.

    ``tables`` maps a twin's path to its table product (``table``: the rule
    name, the page's anchor) and data kind (``data``); without it the file
    stem names the table and the data kind is read from the stem
    (``_surrogate``) or taken as synthetic as in the paper.
    """
    tables = {Path(k).as_posix(): v for k, v in (tables or {}).items()}
    frames = []
    for path in sorted(map(Path, paths)):
        info = tables.get(path.as_posix(), {})
        df = pd.read_csv(path)
        if "modal_order" in df.columns:
            df = _orders_as_cells(df)
            stem = path.stem + "_vs_paper"
        else:
            stem = path.stem
        if df.empty or "paper" not in df.columns:
            continue
        name = stem.replace("_vs_paper", "")
        df.insert(0, "title", _title(path, name))
        df.insert(0, "twin", name)
        df.insert(0, "table", info.get("table", name))
        df.insert(0, "data", info.get("data", "surrogate" if name.endswith("_surrogate") else "synthetic CSM"))
        df.insert(0, "paper_key", path.parent.name)
        df["verdict"] = df.apply(_verdict, axis=1)
        frames.append(df)
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


def _no_interval(df: pd.DataFrame) -> pd.Series:
    """Cells with a reproduced value but no interval (a NaN bound)."""
    return np.isfinite(df["reproduced"]) & ~(np.isfinite(df["ci95_lo"]) & np.isfinite(df["ci95_hi"]))


def summary(df: pd.DataFrame) -> str:
    """One line: how many cells have a paper value and where the paper's value falls (and how many of them have no interval)."""
    counts = df["verdict"].value_counts()
    rated = df["verdict"] != "no paper value"
    n = int(rated.sum())
    line = (f"{n} cells with a paper value: {counts.get('within 95% CI', 0)} within our 95% interval, "
            f"{counts.get('within 25%', 0)} more within 25%, {counts.get('beyond', 0)} beyond.")
    bare = int((rated & _no_interval(df)).sum())
    if bare:
        line += f" {bare} of them with {NO_INTERVAL}: their verdict rests on the 25% ratio alone."
    return line


def table_verdict(t: pd.DataFrame) -> str:
    """One line for one table: its counts and its largest departure (row, column, ratio)."""
    line = summary(t)
    beyond = t[t["verdict"] == "beyond"]
    if len(beyond):
        ratio = (beyond["reproduced"] / beyond["paper"]).replace([np.inf, -np.inf], np.nan)
        if ratio.notna().any():
            worst = beyond.loc[(np.log(ratio.abs())).abs().idxmax()]
            line += f" Largest gap: {worst['row']} / {worst['column']}, {worst['reproduced']:.3g} vs paper {worst['paper']:.3g}."
    return line


def headline(df: pd.DataFrame) -> list[tuple[str, str]]:
    """(data kind label, summary) per data kind present, in :data:`DATA_LABELS` order."""
    return [(DATA_LABELS[k], summary(df[df["data"] == k])) for k in DATA_LABELS if (df["data"] == k).any()]


def _shown(t: pd.DataFrame) -> pd.DataFrame:
    """The cells with readers' column names (the interval as one ``lo - hi`` column)."""
    interval = [f"{lo:.3g} - {hi:.3g}" if np.isfinite(lo) and np.isfinite(hi) else NO_INTERVAL if np.isfinite(m) else "-"
                for m, lo, hi in zip(t["reproduced"], t["ci95_lo"], t["ci95_hi"])]
    out = pd.DataFrame({"row": t["row"].astype(str), "column": t["column"].astype(str), "paper": t["paper"],
                        "reproduced": t["reproduced"], "interval": interval,
                        "ratio": t["reproduced"] / t["paper"].replace(0, np.nan), "verdict": t["verdict"]})
    return out.rename(columns=COLUMNS)


def render(df: pd.DataFrame, figures: Mapping[str, list[tuple[str, str]]] | None = None,
           gallery_link: str = "../figures/index.html") -> tuple[str, str]:
    """(Markdown, HTML) of the comparison page; ``figures``: table -> [(figure rule, its label)] drawn from it."""
    figures = figures or {}
    e = html.escape
    title = "Paper vs reproduced: every table cell"
    md = [f"# {title}", ""]
    head = ["<table><thead><tr><th>data</th><th>cells</th></tr></thead><tbody>"]
    for label, line in headline(df):
        md.append(f"- **{label}**: {line}")
        head.append(f"<tr><td>{e(label)}</td><td>{e(line)}</td></tr>")
    head.append("</tbody></table>")
    md += ["", f"Figures with their verdicts: [figure gallery]({gallery_link}).", "", "## Contents", ""]
    contents, body, seen = [], [], set()
    for key, by_paper in df.groupby("paper_key", sort=True):
        ptitle = PAPERS.get(key, key)
        contents.append(f"<li>{e(ptitle)}<ul>")
        md.append(f"- {ptitle}")
        body.append(f"<h2 id='{e(key)}'>{e(ptitle)}</h2>")
        section = [f"## {ptitle}", ""]
        for (table, twin, heading), t in by_paper.groupby(["table", "twin", "title"], sort=True):
            kind = t["data"].iloc[0]
            anchor = twin  # a table product with several twins is also reachable by its rule name (its first twin)
            extra = "" if table in seen or table == twin else f"<a id='{e(table)}'></a>"
            seen.add(table)
            verdict = table_verdict(t)
            contents.append(f"<li><a href='#{e(anchor)}'>{e(heading)}</a> ({e(kind)}): {e(verdict)}</li>")
            md.append(f"  - [{heading}](#{anchor}) ({kind}): {verdict}")
            figs = figures.get(table, [])
            fig_md = ", ".join(f"[{lab}]({gallery_link}#{name})" for name, lab in figs)
            fig_html = ", ".join(f"<a href='{e(gallery_link)}#{e(name)}'>{e(lab)}</a>" for name, lab in figs)
            section += [f"### {heading}", "", f"<a id='{anchor}'></a>{extra}", "", f"**Data:** {DATA_LABELS[kind]}. **Verdict:** {verdict}"
                        + (f" **Figures:** {fig_md}." if figs else ""), "",
                        _shown(t).to_markdown(index=False, floatfmt=".3g"), ""]
            body.append(f"{extra}<h3 id='{e(anchor)}'>{e(heading)}</h3><p><b>Data:</b> {e(DATA_LABELS[kind])}. <b>Verdict:</b> {e(verdict)}"
                        + (f" <b>Figures:</b> {fig_html}." if figs else "") + "</p><div class='scroll'>"
                        + _shown(t).to_html(index=False, float_format=lambda v: f"{v:.3g}", na_rep="-", border=0) + "</div>")
        contents.append("</ul></li>")
        md += [""] + section
    page = ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            "<meta name='viewport' content='width=device-width, initial-scale=1'><title>Paper vs reproduced</title>"
            "<style>body{font-family:system-ui,sans-serif;margin:0 auto;padding:0 1rem 2rem;max-width:70rem;line-height:1.4}p,li,h1,h2,h3{overflow-wrap:anywhere}"
            "table{border-collapse:collapse;font-size:.85rem}td,th{border:1px solid #ccc;padding:2px 6px;text-align:left}"
            ".scroll{overflow-x:auto}h2{border-bottom:1px solid #ccc;margin-top:2rem}</style></head><body>"
            f"<h1>{e(title)}</h1><div class='scroll'>" + "".join(head) + "</div>"
            + f"<p>Figures with their verdicts: <a href='{e(gallery_link)}'>figure gallery</a>.</p>"
            "<nav><h2>Contents</h2><ul>" + "".join(contents) + "</ul></nav>" + "".join(body) + "</body></html>\n")
    return "\n".join(md) + "\n", page
