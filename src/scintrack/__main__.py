"""Command line.

* ``python -m scintrack verify ARCHIVE_OR_DIR [--against TREE]``: prints one
  line per problem (a kind word, the member, why: :mod:`scintrack.archive.verify`)
  and exits 1 if there is any; a path that does not exist is one ``error:``
  line and exit 2; prints ``OK ...`` (and ``plug-in trackers: ...`` when the
  bundle's provenance names plug-in tracker types) and exits 0 otherwise.
* ``python -m scintrack check-config FILE [FILE ...]``: reads config files
  with the project's loader (a YAML error names the file and line) and exits
  2 with that one line; ``repro.py run`` calls it on every ``--configfile``
  before Snakemake, whose own message does not name the file.
* ``python -m scintrack rules-doc [--write]``: prints the table of every
  workflow rule (:mod:`scintrack.products.rules_table`); ``--write`` puts it into
  ``docs/pipeline.md`` between its markers.
"""

from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scintrack")
    sub = parser.add_subparsers(dest="command", required=True)
    v = sub.add_parser("verify", help="re-check every checksum of a bundle (tar.gz or folder)")
    v.add_argument("bundle")
    v.add_argument("--against", help="also compare the content hashes of the results regenerated in this tree")
    c = sub.add_parser("check-config", help="check that config files are readable YAML mappings")
    c.add_argument("files", nargs="+")
    r = sub.add_parser("rules-doc", help="print the table of every workflow rule (or --write it into docs/pipeline.md)")
    r.add_argument("--write", action="store_true")
    args = parser.parse_args(argv)
    if args.command == "rules-doc":
        return _rules_doc(args.write)
    if args.command == "check-config":
        from pathlib import Path

        from .config import load_config
        from .errors import ConfigError

        for name in args.files:
            if not Path(name).exists() and Path(name).suffix not in (".yaml", ".yml", ".json"):
                print(f"error: config file {name} not found: Snakemake reads every word after --configfile as a config file; "
                      f"if {name!r} is a target, put it before --configfile", file=sys.stderr)
                return 2
        try:
            load_config(args.files)
        except ConfigError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        return 0
    from .archive.verify import verify
    from .errors import InputError, one_line

    try:
        problems = verify(args.bundle, args.against)
    except InputError as exc:
        print(f"error: {one_line(exc)}", file=sys.stderr)
        return 2
    for line in problems:
        print(line)
    if problems:
        print(f"verify: {len(problems)} problem(s) in {args.bundle}", file=sys.stderr)
        return 1
    print(f"OK {args.bundle}: every checksum matches" + (f"; results in {args.against} reproduce the archived content hashes" if args.against else ""))
    from .archive.metadata import bundle_plugin_line

    plugins = bundle_plugin_line(args.bundle)  # code from outside the package that made the results
    if plugins:
        print(plugins)
    return 0


def _rules_doc(write: bool) -> int:
    from pathlib import Path

    from .products.rules_table import current_block, render

    repo = Path.cwd()
    block = render(repo)
    if not write:
        print(block)
        return 0
    doc_path = repo / "docs" / "pipeline.md"
    doc = doc_path.read_text(encoding="utf-8")
    old = current_block(doc)
    doc = doc.replace(old, block) if old is not None else doc.rstrip("\n") + "\n\n## Every rule\n\n" + block + "\n"
    doc_path.write_text(doc, encoding="utf-8")
    print(f"wrote the rules table into {doc_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
