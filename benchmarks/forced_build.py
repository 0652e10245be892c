"""Time a cold build of the forced-response target (`snakemake --cores 2 forced`) of one commit, or of two side by side.

Extracts the committed tree (HEAD by default) into a fresh temporary directory, builds the `forced` target
there with ``PYTHONPATH`` set to that tree's ``src`` (``cold_build.cold_build``) and reports the wall time,
the sum of the jobs' CPU times (the robust measure on a shared machine) and each rule's job times. With
``--compare BASE NEW`` both commits are built in the same run, alternately ``--repeat`` times. The issue's
target: the default scene builds in under a minute on 2 cores.

Usage::

    python benchmarks/forced_build.py [--ref HEAD | --compare BASE NEW] [--repeat 1] [--cores 2]
        [--output benchmarks/forced_build.md]

The machine's load averages before and after are in the report: on a loaded machine the wall time is
dominated by the other processes, the CPU time is not.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from cold_build import cold_build, rule_table
from timing import check_repeat, emit_report


def _load() -> str:
    one, five, _ = os.getloadavg()
    return f"{one:.1f} (1 min), {five:.1f} (5 min)"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ref", default="HEAD")
    parser.add_argument("--compare", nargs=2, metavar=("BASE", "NEW"), help="build both refs in the same run")
    parser.add_argument("--repeat", type=int, default=1, help="builds of each ref (alternating); the best is kept")
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--output", type=Path)
    parser.add_argument("--keep", action="store_true", help="keep the temporary build directories")
    args = parser.parse_args(argv)
    check_repeat(args.repeat)
    refs = args.compare or [args.ref]
    best, loads = {}, [f"Load average before the builds: {_load()}."]
    try:
        for _ in range(args.repeat):
            for ref in refs:
                wall, per_rule, _ = cold_build(ref, args.cores, args.keep, target="forced")
                cpu = sum(entry[2] for entry in per_rule.values())
                print(f"{ref}: {wall:.1f} s wall, {cpu:.1f} s job CPU", file=sys.stderr)
                if ref not in best or cpu < best[ref][1]:
                    best[ref] = (wall, cpu, per_rule)
    except RuntimeError as error:
        print(error, file=sys.stderr)
        return 1
    loads.append(f"Load average after the builds: {_load()}.")
    lines = [
        *loads,
        "",
        f"| ref | wall (s) | job CPU time (s) | job CPU / {args.cores} cores (s) | under 60 s wall |",
        "|---|---:|---:|---:|---|",
    ]
    for ref in refs:
        wall, cpu, _ = best[ref]
        lines.append(f"| `{ref}` | {wall:.1f} | {cpu:.1f} | {cpu / args.cores:.1f} | {'yes' if wall < 60 else 'no'} |")
    if args.compare:
        (base, new) = refs
        lines += ["", f"CPU time ratio `{new}` / `{base}`: {best[new][1] / best[base][1]:.2f}."]
    for ref in refs:
        lines += ["", *rule_table(ref, args.cores, best[ref][0], best[ref][2], target="forced")]
    return emit_report("\n".join(lines), args.output)


if __name__ == "__main__":
    sys.exit(main())
