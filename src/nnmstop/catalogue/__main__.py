"""``python -m nnmstop.catalogue [--check PAGE]``: print the dataset reference page, or check a copy of it."""

import argparse
import sys
from pathlib import Path

from nnmstop.catalogue import markdown


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m nnmstop.catalogue", description=__doc__)
    parser.add_argument("--check", metavar="PAGE", help="exit 1 if PAGE (docs/datasets.md) differs from the catalogue")
    args = parser.parse_args(argv)
    page = markdown()
    if args.check is None:
        sys.stdout.write(page)
        return 0
    if Path(args.check).read_text() != page:
        print(f"{args.check} is out of date: python -m nnmstop.catalogue > {args.check}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
