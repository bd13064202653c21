"""The figure gallery: every figure with its paper figure, the paper's claim, our verdict and its data.

Each figure rule writes one record beside its figure (:func:`figure_record`,
``<stem>.json``); the gallery rule reads them all and writes
``figures/index.md`` and ``figures/index.html`` (:func:`render_gallery`).  The
HTML page is self-contained apart from the PNG files beside it (relative
links, no script, no network), and its layout is one column on a narrow
screen.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from ..io import write_text


def figure_record(product, data_kind: str, verdict, problems: list[str], png: str | os.PathLike) -> dict:
    """The gallery entry of one figure (JSON-ready; sorted keys keep its bytes stable)."""
    from .registry import PAPERS

    if verdict is None:
        status = "no paper figure" if product.number is None else "not reproduced"
        text = "" if product.number is None else "no verdict computed for this figure"
    else:
        status, text = verdict.status, verdict.text
    return {
        "name": product.name,
        "paper": product.paper,
        "paper_title": PAPERS[product.paper],
        "section": product.section,
        "number": product.number,
        "claim": product.claim,
        "verdict": {"status": status, "text": text},
        "data": data_kind,
        "tables": list(product.tables),
        "png": Path(png).name,
        "pdf": Path(png).with_suffix(".pdf").name,
        "layout_problems": list(problems),
    }


def write_record(record: dict, path: str | os.PathLike) -> None:
    write_text(json.dumps(record, indent=1, sort_keys=True, ensure_ascii=False) + "\n", path)


def read_records(paths) -> list[dict]:
    """The records at ``paths`` (each with ``folder``: its path's parent, relative links start there)."""
    out = []
    for p in map(Path, paths):
        try:
            rec = json.loads(p.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise ValueError(f"{p}: not a figure record ({exc}); rerun its figure rule") from None
        rec["folder"] = p.parent.name
        out.append(rec)
    return out


#: order and colour of the verdicts on the page
STATUS_COLOURS = {"reproduced": "#1b7837", "differs": "#b35806", "not reproduced": "#b2182b", "no paper figure": "#555555"}
#: the data kinds as a reader names them
DATA_LABELS = {
    "synthetic CSM": "synthetic CSM (as in the paper)",
    "surrogate": "synthetic surrogate of real traces",
    "synthetic SKYDEL-like": "synthetic SKYDEL-like",
    "real": "real recordings",
    "mixed": "mixed (CSM, SKYDEL-like, traces)",
}


def _figure_heading(rec: dict) -> str:
    return f"{rec['paper_title']}, {rec['number']}" if rec["number"] else f"{rec['paper_title']}, added figure ({rec['name']})"


def _counts(records: list[dict]) -> list[tuple[str, dict[str, int]]]:
    """Per data kind (in :data:`DATA_LABELS` order): verdict status -> number of figures."""
    out = []
    for kind in DATA_LABELS:
        of_kind = [r for r in records if r["data"] == kind]
        if of_kind:
            out.append((kind, {s: sum(r["verdict"]["status"] == s for r in of_kind) for s in STATUS_COLOURS}))
    return out


def _count_line(counts: dict[str, int]) -> str:
    return ", ".join(f"{n} {s}" for s, n in counts.items() if n)


def _ordered(records: list[dict]) -> list[dict]:
    from .registry import PAPERS

    papers = list(PAPERS)
    return sorted(records, key=lambda r: (papers.index(r["paper"]) if r["paper"] in papers else len(papers), r["number"] is None,
                                          _fig_key(r["number"]), r["name"]))


def _fig_key(number: str | None) -> tuple[int, str]:
    digits = "".join(ch for ch in (number or "") if ch.isdigit())
    return (int(digits) if digits else 10**6, number or "")


def render_markdown(records: list[dict], compare_link: str) -> str:
    """``figures/index.md``: the gallery as Markdown (images and links relative to ``figures/``)."""
    records = _ordered(records)
    lines = ["# Figure gallery", "",
             "Every figure of the reproduction: the paper's figure number and claim, our verdict with the number it rests on, "
             f"and the data it is drawn from. Table cells beside the paper's values: [{compare_link}]({compare_link}).", ""]
    lines += ["| data | figures | verdicts |", "|---|---|---|"]
    lines += [f"| {DATA_LABELS[kind]} | {sum(c.values())} | {_count_line(c)} |" for kind, c in _counts(records)]
    lines.append("")
    paper = None
    for rec in records:
        if rec["paper_title"] != paper:
            paper = rec["paper_title"]
            lines += [f"## {paper}", ""]
        v = rec["verdict"]
        lines += [f"### {_figure_heading(rec)}", "", f"![{rec['name']}]({rec['folder']}/{rec['png']})", ""]
        if rec["claim"]:
            lines.append(f"- **Paper:** {rec['claim']}")
        lines.append(f"- **Verdict: {v['status']}**" + (f". {v['text']}" if v["text"] else ""))
        lines.append(f"- **Data:** {DATA_LABELS[rec['data']]}")
        if rec["tables"]:
            lines.append("- **Table cells:** " + ", ".join(f"[{t}]({compare_link}#{t})" for t in rec["tables"]))
        lines.append(f"- **Files:** [{rec['png']}]({rec['folder']}/{rec['png']}), [{rec['pdf']}]({rec['folder']}/{rec['pdf']})")
        lines.append("")
    return "\n".join(lines)


_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:0;padding:0 1rem 2rem;line-height:1.4;color:#222}
header{max-width:70rem;margin:auto}
main{max-width:70rem;margin:auto}
h1{font-size:1.5rem}h2{font-size:1.25rem;margin-top:2rem;border-bottom:1px solid #ccc}h3{font-size:1rem;margin:.2rem 0}
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(min(100%,30rem),1fr));gap:1rem}
figure{margin:0;border:1px solid #ddd;border-radius:6px;padding:.6rem;background:#fff}
figure img{width:100%;height:auto;display:block}
figcaption p{margin:.3rem 0;font-size:.9rem}
.badge{display:inline-block;color:#fff;border-radius:3px;padding:0 .4rem;font-size:.85rem}
.data{display:inline-block;border:1px solid #888;border-radius:3px;padding:0 .4rem;font-size:.85rem}
table{border-collapse:collapse;font-size:.9rem}td,th{border:1px solid #ccc;padding:.15rem .5rem;text-align:left}
nav ul{columns:2 16rem;padding-left:1.2rem}
"""


#: widest preview embedded in the page [pixels]; the full-size PNG and the PDF are linked
PREVIEW_WIDTH = 1000


def preview(png: bytes, width: int = PREVIEW_WIDTH) -> bytes:
    """The figure as it is embedded in the page: at most ``width`` pixels wide and in 256 colours
    (a line plot has few), which makes the page about a third of the size of the PNGs it shows.
    Deterministic: the same PNG gives the same bytes."""
    import io

    from PIL import Image

    im = Image.open(io.BytesIO(png)).convert("RGB")
    if im.width > width:
        im = im.resize((width, round(im.height * width / im.width)), Image.Resampling.LANCZOS)
    out = io.BytesIO()
    im.quantize(colors=256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE).save(out, format="PNG", optimize=True)
    return out.getvalue()


def render_html(records: list[dict], images: dict[str, bytes], compare_link: str) -> str:
    """``figures/index.html``: one self-contained page (every figure embedded as a data URI,
    :func:`preview`; no script, no network), one column on a narrow screen."""
    import base64
    import html

    records = _ordered(records)
    e = html.escape
    rows = "".join(f"<tr><td>{e(DATA_LABELS[kind])}</td><td>{sum(c.values())}</td><td>{e(_count_line(c))}</td></tr>"
                   for kind, c in _counts(records))
    contents, cards, paper = [], [], None
    for rec in records:
        if rec["paper_title"] != paper:
            if paper is not None:
                cards.append("</div>")
            paper = rec["paper_title"]
            cards.append(f"<h2 id='{e(rec['paper'])}'>{e(paper)}</h2><div class='grid'>")
        v = rec["verdict"]
        heading = _figure_heading(rec)
        contents.append(f"<li><a href='#{e(rec['name'])}'>{e(heading)}</a> <span class='badge' "
                        f"style='background:{STATUS_COLOURS[v['status']]}'>{e(v['status'])}</span></li>")
        src = "data:image/png;base64," + base64.b64encode(preview(images[rec["name"]])).decode("ascii")
        links = [f"<a href='{e(rec['folder'])}/{e(rec['pdf'])}'>PDF</a>", f"<a href='{e(rec['folder'])}/{e(rec['png'])}'>PNG</a>"]
        links += [f"<a href='{e(compare_link)}#{e(t)}'>{e(t)} cells</a>" for t in rec["tables"]]
        cards.append(
            f"<figure id='{e(rec['name'])}'><h3>{e(heading)}</h3>"
            f"<img src='{src}' alt='{e(heading)}: {e(rec['claim'] or rec['name'])}'>"
            "<figcaption>"
            + (f"<p><b>Paper:</b> {e(rec['claim'])}</p>" if rec["claim"] else "")
            + f"<p><span class='badge' style='background:{STATUS_COLOURS[v['status']]}'>{e(v['status'])}</span> {e(v['text'])}</p>"
            f"<p><span class='data'>{e(DATA_LABELS[rec['data']])}</span> {' · '.join(links)}</p>"
            "</figcaption></figure>")
    if paper is not None:
        cards.append("</div>")
    return ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            "<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>Figure gallery</title><style>{_CSS}</style></head><body><header><h1>Figure gallery</h1>"
            "<p>Every figure of the reproduction with the paper's figure number and claim, our verdict with the number it rests on, "
            f"and the data it is drawn from. Every table cell beside the paper's value: <a href='{e(compare_link)}'>comparison page</a>.</p>"
            f"<table><thead><tr><th>data</th><th>figures</th><th>verdicts</th></tr></thead><tbody>{rows}</tbody></table>"
            f"<nav><h2>Contents</h2><ul>{''.join(contents)}</ul></nav></header><main>{''.join(cards)}</main></body></html>\n")


def render_gallery(record_paths, md_path, html_path, compare_link: str = "../tables/compare.html") -> None:
    """Read the figure records (and their PNGs beside them) and write the Markdown and HTML gallery."""
    records = read_records(record_paths)
    images = {}
    for path, rec in zip(map(Path, record_paths), records):
        png = path.parent / rec["png"]
        try:
            images[rec["name"]] = png.read_bytes()
        except OSError:
            raise ValueError(f"{png}: missing figure image of {path}; rerun its figure rule") from None
    write_text(render_markdown(records, compare_link), md_path)
    write_text(render_html(records, images, compare_link), html_path)
