"""Command line.

* ``python -m scintrack verify ARCHIVE_OR_DIR [--against TREE]``: prints one
  line per mismatch and exits 1 if there is any (2 for a path that does not
  exist); prints ``OK ...`` and exits 0 otherwise.
* ``python -m scintrack check-config FILE [FILE ...]``: reads config files
  with the project's loader (a YAML error names the file and line) and exits
  2 with that one line; ``repro.py run`` calls it on every ``--configfile``
  before Snakemake, whose own message does not name the file.
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
    args = parser.parse_args(argv)
    if args.command == "check-config":
        from pathlib import Path

        from .config import ConfigError, load_config

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

    try:
        problems = verify(args.bundle, args.against)
    except FileNotFoundError as exc:
        print(f"verify: {exc}", file=sys.stderr)
        return 2
    for line in problems:
        print(line)
    if problems:
        print(f"verify: {len(problems)} problem(s) in {args.bundle}", file=sys.stderr)
        return 1
    print(f"OK {args.bundle}: every checksum matches" + (f"; results in {args.against} reproduce the archived content hashes" if args.against else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
