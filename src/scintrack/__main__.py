"""Command line: ``python -m scintrack verify ARCHIVE_OR_DIR [--against TREE]``.

Prints one line per mismatch and exits 1 if there is any (2 for a path that
does not exist); prints ``OK ...`` and exits 0 otherwise.
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
    args = parser.parse_args(argv)
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
