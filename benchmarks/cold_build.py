"""Time a cold build of the whole pipeline and each rule's share.

Extracts the committed tree (HEAD) into a fresh temporary directory (no
``results/``, no ``.snakemake/``), runs ``snakemake --cores N`` there (the default
target: every figure, dataset and the manifest), and reads the per-job
``benchmark:`` files to report each rule's wall time.

Usage::

    python benchmarks/cold_build.py [--cores 2] [--output benchmarks/cold_build.md] [--keep]

Run it on an otherwise idle machine: it measures wall time.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import pandas as pd

REPO = Path(__file__).resolve().parents[1]


def tracked_copy(destination: Path) -> None:
    """Extract the committed tree (HEAD) into ``destination``, as a fresh clone would have it."""
    archive = subprocess.run(["git", "-C", str(REPO), "archive", "HEAD"], capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(destination)], input=archive, check=True)


def rule_of(benchmark_file: Path) -> str:
    """Rule name of a benchmark file (``hbm_nnm1_stage2.tsv`` -> ``hbm_stage``)."""
    stem = benchmark_file.stem
    if re.fullmatch(r"hbm_nnm\d_stage\d+", stem):
        return "hbm_stage"
    if re.fullmatch(r"hbm_nnm\d", stem):
        return "hbm_branch"
    return stem


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--output", type=Path, help="also write the Markdown table here")
    parser.add_argument("--keep", action="store_true", help="keep the temporary build directory")
    args = parser.parse_args(argv)

    workdir = Path(tempfile.mkdtemp(prefix="nnmstop-cold-"))
    try:
        tracked_copy(workdir)
        started = time.perf_counter()
        run = subprocess.run(["snakemake", "--cores", str(args.cores), "--quiet", "all"], cwd=workdir)
        wall = time.perf_counter() - started
        if run.returncode != 0:
            print(f"snakemake failed (exit {run.returncode}) in {workdir}", file=sys.stderr)
            return run.returncode
        per_rule: dict[str, float] = defaultdict(float)
        jobs: dict[str, int] = defaultdict(int)
        for tsv in sorted((workdir / "benchmarks" / "runs").glob("*.tsv")):
            table = pd.read_csv(tsv, sep="\t")
            name = rule_of(tsv)
            per_rule[name] += float(table["s"].iloc[0])
            jobs[name] += 1
        total_jobs = sum(per_rule.values())
        lines = [
            f"Cold build with `snakemake --cores {args.cores}`: **{wall:.1f} s** wall "
            f"(sum of job wall times {total_jobs:.1f} s).",
            "",
            "| rule | jobs | job wall time (s) | share of job time |",
            "|---|---:|---:|---:|",
        ]
        for name, seconds in sorted(per_rule.items(), key=lambda kv: -kv[1]):
            lines.append(f"| {name} | {jobs[name]} | {seconds:.1f} | {100 * seconds / total_jobs:.0f} % |")
        report = "\n".join(lines)
        print(report)
        if args.output:
            args.output.write_text(report + "\n")
    finally:
        if args.keep:
            print(f"build kept in {workdir}")
        else:
            shutil.rmtree(workdir, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
