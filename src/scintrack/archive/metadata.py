"""Metadata files of a bundle: provenance, CITATION.cff, .zenodo.json and a
Workflow Run RO-Crate (``ro-crate-metadata.json``, written directly as JSON-LD:
the profile needs a handful of entities, not a library).

Nothing here reads the clock: the same tree gives the same bytes.

Plug-in tracker types (``docs/adding-a-tracker.md``) are code outside the
package: ``provenance.json`` lists those the config's trackers use
(``plugin_trackers``: type, entry point, distribution, version and the
SHA-256 of the plug-in's normalised sources, :func:`plugin_trackers`), and
``verify`` prints them (:func:`bundle_plugin_line`).  A bundle without
plug-ins has no such key, so its bytes do not depend on this.
"""

from __future__ import annotations

import csv
import json
import platform
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from .. import __version__
from .tarball import sha256_bytes

TITLE = "scintrack: reproduction of GNSS carrier tracking under ionospheric scintillation and jamming"
DESCRIPTION = (
    "Snakemake pipeline, data, results, figures and tables reproducing Vila-Valls et al. 2018 "
    "(On the Mitigation of Ionospheric Scintillation in Advanced GNSS Receivers, IEEE TAES), with "
    "paper-vs-reproduced comparisons. Sec. VI-E outputs marked 'surrogate' come from a synthetic "
    "phase-screen stand-in, not from the JRC Hanoi traces."
)
CREATORS = [{"name": "scintrack contributors"}]
PAPER_DOIS = {
    "Vila-Valls et al. 2018, IEEE TAES 54(4)": "10.1109/TAES.2018.2798480",
    "Susi, Andreotti, Aquino 2014 (InTech chapter)": "10.5772/58769",
}


def benchmark_timings(paths) -> list[dict[str, Any]]:
    """Wall seconds per job from Snakemake ``benchmark:`` files."""
    rows = []
    for path in sorted(map(Path, paths)):
        with open(path) as fh:
            rec = next(csv.DictReader(fh, delimiter="\t"), None)
        if rec:
            rows.append({"job": path.as_posix(), "seconds": float(rec["s"]), "max_rss_mb": _num(rec.get("max_rss"))})
    return rows


def _num(v):
    try:
        return float(v)
    except (TypeError, ValueError):
        return None


def provenance(*, config: Mapping[str, Any], git: Mapping[str, Any], lock_text: str, timings: list, name: str, version: str) -> bytes:
    doc = {
        "bundle": f"{name}-{version}",
        "scintrack_version": __version__,
        "git_commit": git.get("git_commit"),
        "git_dirty": bool(git.get("git_dirty")),
        "platform": {"python": platform.python_version(), "implementation": platform.python_implementation(), "machine": platform.machine(), "system": platform.system()},
        "config": config,
        "environment_lock_sha256": sha256_bytes(lock_text.encode()),
        "timings_per_job": timings,
    }
    plugins = plugin_trackers(config)
    if plugins:
        doc["plugin_trackers"] = plugins
    return (json.dumps(doc, indent=2, sort_keys=True, default=str) + "\n").encode()


def plugin_trackers(config: Mapping[str, Any]) -> list[dict[str, str]]:
    """The plug-in tracker types of the config's trackers, as installed now (:func:`scintrack.codeversion.plugin_code`)."""
    from ..codeversion import plugin_code

    trackers = config.get("trackers") or {}
    return plugin_code(str(spec["type"]) for spec in trackers.values() if isinstance(spec, Mapping) and "type" in spec)


def plugin_line(provenance_json: bytes) -> str | None:
    """``"plug-in trackers: <distribution> <version> (source sha256 <16 hex>); ..."`` of a bundle's ``provenance.json``,
    None when it names no plug-in (or cannot be read: ``verify`` reports that)."""
    from ..codeversion import describe_plugins

    try:
        records = json.loads(provenance_json).get("plugin_trackers") or []
        text = describe_plugins(records)
    except (ValueError, AttributeError, TypeError, KeyError):
        return None
    return f"plug-in trackers: {text}" if text else None


def bundle_plugin_line(bundle: str | Path) -> str | None:
    """:func:`plugin_line` of the ``provenance.json`` of a bundle (tar.gz or unpacked folder), read without extracting
    (a tar.gz is read only up to that member, which sorts before the results)."""
    import tarfile

    path = Path(bundle)
    if path.is_dir():
        member = path / "provenance.json"
        return plugin_line(member.read_bytes()) if member.is_file() and not member.is_symlink() else None
    try:
        with tarfile.open(path, "r:gz") as tar:
            for info in tar:
                if info.isfile() and info.name.count("/") == 1 and info.name.endswith("/provenance.json"):
                    handle = tar.extractfile(info)
                    return plugin_line(handle.read()) if handle is not None else None
    except (OSError, tarfile.TarError, EOFError):
        return None
    return None


def citation_cff(version: str, commit: str) -> bytes:
    doc = {
        "cff-version": "1.2.0",
        "message": "If you use this reproduction, please cite it and the original papers.",
        "title": TITLE,
        "version": version,
        "commit": commit,
        "type": "software",
        "authors": [{"name": c["name"]} for c in CREATORS],
        "abstract": DESCRIPTION,
        "references": [{"type": "article", "title": k, "doi": v, "authors": [{"name": k.split(" ")[0]}]} for k, v in PAPER_DOIS.items()],
    }
    return yaml.safe_dump(doc, sort_keys=False, allow_unicode=True).encode()


def zenodo_json(version: str) -> bytes:
    doc = {
        "title": TITLE,
        "upload_type": "software",
        "version": version,
        "description": DESCRIPTION,
        "creators": CREATORS,
        "license": "other-open",
        "related_identifiers": [{"identifier": doi, "relation": "isSupplementTo", "scheme": "doi", "resource_type": "publication-article"} for doi in PAPER_DOIS.values()],
        "keywords": ["GNSS", "carrier tracking", "ionospheric scintillation", "Kalman filter", "reproducibility"],
    }
    return (json.dumps(doc, indent=2, sort_keys=True) + "\n").encode()


def ro_crate(members: Mapping[str, bytes], *, name: str, version: str, commit: str, config_name: str = "config.yaml") -> bytes:
    """Workflow Run RO-Crate (process/workflow run profiles) describing the bundle."""
    files = sorted(members)
    graph = [
        {"@id": "ro-crate-metadata.json", "@type": "CreativeWork", "about": {"@id": "./"},
         "conformsTo": [{"@id": "https://w3id.org/ro/crate/1.1"}, {"@id": "https://w3id.org/ro/wfrun/workflow/0.5"}]},
        {"@id": "./", "@type": "Dataset", "name": f"{name}-{version}", "description": DESCRIPTION, "version": version,
         "hasPart": [{"@id": f} for f in files] + [{"@id": "Snakefile"}], "mainEntity": {"@id": "Snakefile"},
         "mentions": {"@id": "#run"},
         "conformsTo": [{"@id": "https://w3id.org/ro/wfrun/process/0.5"}, {"@id": "https://w3id.org/ro/wfrun/workflow/0.5"}]},
        {"@id": "Snakefile", "@type": ["File", "SoftwareSourceCode", "ComputationalWorkflow"], "name": "scintrack Snakemake workflow",
         "programmingLanguage": {"@id": "#snakemake"}, "version": commit},
        {"@id": "#snakemake", "@type": "ComputerLanguage", "name": "Snakemake", "url": {"@id": "https://snakemake.github.io"}},
        {"@id": "#run", "@type": "CreateAction", "name": f"snakemake --cores 2 ({name}-{version})", "instrument": {"@id": "Snakefile"},
         "object": [{"@id": f} for f in files if f.startswith(("config/", "registry/", "data/"))],
         "result": [{"@id": f} for f in files if f.startswith(("figures/", "tables/", "results/"))]},
    ]
    for f in files:
        graph.append({"@id": f, "@type": "File", "contentSize": len(members[f]), "sha256": sha256_bytes(members[f])})
    return (json.dumps({"@context": "https://w3id.org/ro/crate/1.1/context", "@graph": graph}, indent=1, sort_keys=True) + "\n").encode()
