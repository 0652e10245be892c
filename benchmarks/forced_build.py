"""Time a cold build of the forced-response target (`snakemake --cores 2 forced`) of a commit.

Extracts the committed tree (HEAD by default) into a fresh temporary directory, builds the `forced` target
there with ``PYTHONPATH`` set to that tree's ``src`` (``cold_build.cold_build``) and reports the wall time and
each rule's job times. The issue's target: the default scene builds in under a minute on 2 cores.

Usage::

    python benchmarks/forced_build.py [--ref HEAD] [--cores 2] [--output benchmarks/forced_build.md]

Run it on an otherwise idle machine: it measures wall time.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
from pathlib import Path

from cold_build import cold_build, rule_table
from timing import emit_report


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ref", default="HEAD")
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--output", type=Path)
    parser.add_argument("--keep", action="store_true", help="keep the temporary build directory")
    args = parser.parse_args(argv)
    try:
        wall, per_rule, _ = cold_build(args.ref, args.cores, args.keep, target="forced")
    except RuntimeError as error:
        print(error, file=sys.stderr)
        return 1
    load = os.getloadavg()
    lines = [
        f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, load average before the "
        f"report {load[0]:.1f} (1 min) {load[1]:.1f} (5 min).",
        "",
        *rule_table(args.ref, args.cores, wall, per_rule),
        "",
        f"Target: under 60 s on 2 cores -> {'met' if wall < 60 else 'NOT met'} ({wall:.1f} s).",
    ]
    return emit_report("\n".join(lines), args.output)


if __name__ == "__main__":
    sys.exit(main())
