"""Publication rule entry point: build the byte-reproducible bundle."""

import sys
from pathlib import Path

import scintrack
from scintrack import jobcode
from scintrack.archive.build import ArchiveRefused, check_results_config, check_tree, collect_members, finish
from scintrack.archive.metadata import benchmark_timings
from scintrack.archive.tarball import write_tarball
from scintrack.errors import InputError
from scintrack.io import git_state

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "archive")
cfg = sm.params.config
git = git_state(Path(scintrack.__file__).resolve().parent)
try:
    check_tree(git, bool(sm.params.allow_dirty), [sm.input.figure_sums, sm.input.table_sums])
    check_results_config(cfg, sm.input.results)
except ArchiveRefused as exc:
    raise InputError(str(exc)) from None
outputs = [*sm.input.figures, *sm.input.tables, *sm.input.compare, *sm.input.gallery, sm.input.manifest, sm.input.figure_sums, sm.input.table_sums]
extra = {"environment.lock": sm.input.lock, "registry/registry.yaml": sm.input.registry}
members, manifest = collect_members(outputs=outputs, results=sm.input.results, extra=extra, max_result_mb=float(sm.params.max_result_mb))
timings = benchmark_timings(sorted(Path("results/benchmarks").rglob("*.tsv")))
members = finish(members, config=cfg, git=git, timings=timings, name=sm.params.name, version=sm.params.version)
digest = write_tarball(members, sm.output[0], root=f"{sm.params.name}-{sm.params.version}")
size = Path(sm.output[0]).stat().st_size
msg = f"{sm.output[0]}: {len(members)} files, {size / 1e6:.1f} MB, sha256 {digest}; {len(manifest['listed_only'])} large results listed by hash only"
log.info("%s", msg)
print(msg, file=sys.stderr)
