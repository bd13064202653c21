"""The code a workflow job runs, checked against the code its rule was planned with.

Every rule gets the code version of its script and of the package modules the
script reaches as its ``code`` param (:func:`planned`, computed when Snakemake
builds the DAG), so editing a module reruns exactly the rules that import it.
A module edited *after* the DAG was planned would otherwise slip through: the
job would import the edited module while its output is recorded under the
planned version, and after the edit is reverted ``snakemake -n`` would see
nothing to do and keep output of code that is in no commit.

So a job checks twice (every workflow script calls :func:`begin` after its
imports; :mod:`scintrack.io` and the figure writer call the check it leaves in
:data:`scintrack.io.JOB` before every output is renamed into place): the code version
computed from the files on disk now, by the same normalised-source hash
(:func:`scintrack.codeversion.code_version`), must equal the planned one.  A
difference ends the job with one line, ``source changed during the run``, and
no output is written.  What ran (the code version and the git state at the
job's start) is recorded in every result's attributes
(:func:`scintrack.io.provenance`).

A rule that runs plug-in tracker types (``docs/adding-a-tracker.md``) names
them (:func:`planned`'s ``trackers``): its code version then also covers each
plug-in's distribution, version and normalised source
(:func:`scintrack.codeversion.plugin_code`), is checked the same way, and
reads ``<version> + plug-ins: <distribution> <version> (source sha256 ...)``
in the result's ``code_version``.  A rule without plug-in types has the same
``code`` param as without this mechanism.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from . import io, runlog
from .codeversion import clear_caches, code_version, plugin_code, with_plugins
from .errors import InputError


class CodeChanged(InputError):
    """The package or script changed between planning a job and running (or finishing) it."""


def planned(scripts: Path, script: str, *modules: str, trackers: Iterable[str] = ()) -> dict[str, Any]:
    """The ``code`` param of a rule: the code version of ``scripts/script`` and ``modules``, with what it covers
    (names relative to the scripts folder and the package, so the param does not depend on the checkout's path).

    ``trackers``: the tracker types the rule runs; those that are plug-ins add their code (module docstring)
    and are listed under ``plugins``.
    """
    version = code_version([Path(scripts) / script, *modules])
    plugins = plugin_code(trackers)
    out = {"version": with_plugins(version, plugins), "script": script, "modules": list(modules)}
    if plugins:
        out["plugins"] = plugins
    return out


def _now(code: Mapping[str, Any], scriptdir: str | Path) -> str:
    clear_caches()  # re-read the sources (the disk cache is keyed by the files' bytes, so it cannot be stale)
    version = code_version([Path(scriptdir) / code["script"], *code["modules"]])
    return with_plugins(version, plugin_code(p["type"] for p in code.get("plugins", ())))


def _refuse(code: Mapping[str, Any], now: str, when: str) -> CodeChanged:
    covers = ", ".join([code["script"], *code["modules"], *dict.fromkeys(p["distribution"] for p in code.get("plugins", ()))])
    return CodeChanged(f"source changed during the run: the code of {covers} is {now} {when}, the rule was planned with "
                       f"{code['version']}; nothing was written, rerun snakemake")


def start(code: Mapping[str, Any], scriptdir: str | Path, git: Mapping[str, Any]) -> None:
    """Check the code on disk against the plan at the job's start and leave what runs, and the check every output
    passes, in :data:`scintrack.io.JOB` (see the module docstring)."""
    now = _now(code, scriptdir)
    if now != code["version"]:
        raise _refuse(code, now, "at the job's start")
    plan = dict(code)

    def confirm() -> None:
        later = _now(plan, scriptdir)
        if later != plan["version"]:
            raise _refuse(plan, later, "now")

    io.JOB.clear()
    io.JOB.update(ran={"code_version": now, **git}, confirm=confirm)


def begin(sm, name: str):
    """Start a workflow job (its Snakemake object ``sm``): :func:`scintrack.runlog.setup`, then :func:`start` with
    the rule's ``code`` param and the git state now; returns the job's logger."""
    logger = runlog.setup(sm.log[0] if sm.log else None, name)
    start(sm.params.code, sm.scriptdir, io.git_state(Path(__file__).resolve().parent))
    return logger
