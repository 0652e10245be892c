"""Time a cold build of the whole pipeline and each rule's share, for one or two commits.

Extracts a committed tree (HEAD by default) into a fresh temporary directory (no
``results/``, no ``.snakemake/``), runs ``snakemake --cores N`` there (the default
target: every figure, dataset and the manifest) with ``PYTHONPATH`` set to that
tree's ``src`` (the package of that commit, not the installed one), and reads the
per-job ``benchmark:`` files to report each rule's wall time (and the CPU time of jobs run by
the warm worker from their logs).

``--compare A B`` builds both refs in the same run, alternately ``--repeat`` times
(A, B, A, B, ...), and reports the best wall time of each side by side with the
ratio B/A, then each ref's per-rule table of its best run.

Usage::

    python benchmarks/cold_build.py [--cores 2] [--output benchmarks/cold_build.md] [--keep]
    python benchmarks/cold_build.py --compare cf04ec5 HEAD [--repeat 2] [--cores 2]

Run it on an otherwise idle machine: it measures wall time.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import pandas as pd

from timing import check_repeat, emit_report

REPO = Path(__file__).resolve().parents[1]


def tracked_copy(destination: Path, ref: str = "HEAD") -> None:
    """Extract the committed tree of ``ref`` into ``destination``, as a fresh clone would have it."""
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref], capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(destination)], input=archive, check=True)


def rule_of(benchmark_file: Path) -> str:
    """Rule name of a benchmark file (``hbm_nnm1_stage2.tsv`` -> ``hbm_stage``, ``forced_exact_F0.1.tsv`` ->
    ``forced_exact``)."""
    stem = benchmark_file.stem
    if re.fullmatch(r"hbm_nnm\d_stage\d+", stem):
        return "hbm_stage"
    if re.fullmatch(r"hbm_nnm\d", stem):
        return "hbm_branch"
    if stem.startswith("hbm_bifurcated_"):
        return "hbm_bifurcated"
    forced = re.fullmatch(r"(forced_(?:exact|regularized|figure))_.+", stem)  # one job per scene or figure
    if forced:
        return forced.group(1)
    return stem


def cold_build(ref: str, cores: int, keep: bool, target: str = "all", configfile: Path | None = None):
    """Build ``target`` of ``ref`` cold; return its wall time and per-rule job times ``{rule: (jobs, seconds)}``.

    ``configfile`` (a path outside the tree) replaces the tree's own ``config/config.yaml``.
    """
    workdir = Path(tempfile.mkdtemp(prefix="nnmstop-cold-"))
    try:
        tracked_copy(workdir, ref)
        env = {**os.environ, "PYTHONPATH": str(workdir / "src")}
        config = ["--configfile", str(Path(configfile).resolve())] if configfile else []
        started = time.perf_counter()
        # the target first: --quiet takes optional values and --configfile a list
        command = [sys.executable, "-m", "snakemake", target, "--cores", str(cores), "--quiet", "all", *config]
        run = subprocess.run(command, cwd=workdir, env=env)
        wall = time.perf_counter() - started
        if run.returncode != 0:
            raise RuntimeError(f"snakemake failed for {ref} (exit {run.returncode}) in {workdir}")
        per_rule: dict[str, list] = defaultdict(lambda: [0, 0.0, 0.0])
        for tsv in sorted((workdir / "benchmarks" / "runs").glob("*.tsv")):
            table = pd.read_csv(tsv, sep="\t")
            entry = per_rule[rule_of(tsv)]
            entry[0] += 1
            entry[1] += float(table["s"].iloc[0])
            entry[2] += float(table["cpu_time"].iloc[0])
        # A job run by the warm worker (nnmstop.pipeline.worker) does its work in a fork of the worker,
        # outside the job's process tree that Snakemake's benchmark measures: its CPU time is in its log.
        worker_line = r"task (\w+) ran in the warm worker: [0-9.]+ s wall, ([0-9.]+) s CPU"
        for log in sorted((workdir / "logs").rglob("*.log")):
            for task, cpu in re.findall(worker_line, log.read_text()):
                per_rule[task][2] += float(cpu)
        # Stability time of the hbm_stage jobs, from their logs (commits that log it).
        stability = 0.0
        for log in sorted((workdir / "logs" / "hbm").glob("nnm*_stage*.log")):
            stability += sum(float(m) for m in re.findall(r"stability of \d+ points in ([0-9.]+) s", log.read_text()))
        return wall, dict(per_rule), stability
    finally:
        if keep:
            print(f"build of {ref} kept in {workdir}")
        else:
            shutil.rmtree(workdir, ignore_errors=True)


def rule_table(ref: str, cores: int, wall: float, per_rule: dict, target: str = "all") -> list[str]:
    total_jobs = sum(entry[1] for entry in per_rule.values())
    lines = [
        f"Cold build of `{ref}` with `snakemake --cores {cores} {target}`: **{wall:.1f} s** wall "
        f"(sum of job wall times {total_jobs:.1f} s, of job CPU times {sum(e[2] for e in per_rule.values()):.1f} s).",
        "",
        "| rule | jobs | job wall time (s) | share of job time | job CPU time (s) |",
        "|---|---:|---:|---:|---:|",
    ]
    for name, (jobs, seconds, cpu) in sorted(per_rule.items(), key=lambda kv: -kv[1][1]):
        lines.append(f"| {name} | {jobs} | {seconds:.1f} | {100 * seconds / total_jobs:.0f} % | {cpu:.1f} |")
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--compare", nargs=2, metavar=("BASE", "NEW"), help="build both refs in the same run")
    parser.add_argument("--repeat", type=int, default=1, help="builds of each ref (alternating); the best is kept")
    parser.add_argument("--output", type=Path, help="also write the Markdown table here")
    parser.add_argument("--keep", action="store_true", help="keep the temporary build directories")
    parser.add_argument("--target", default="all", help="what to build (default: the default target, every figure)")
    parser.add_argument("--configfile", type=Path, help="a configuration to build with instead of the tree's own")
    args = parser.parse_args(argv)
    check_repeat(args.repeat)
    refs = args.compare or ["HEAD"]
    best: dict[str, tuple] = {}
    try:
        for _ in range(args.repeat):
            for ref in refs:
                wall, per_rule, stability = cold_build(ref, args.cores, args.keep, args.target, args.configfile)
                print(f"{ref}: {wall:.1f} s", file=sys.stderr)
                if ref not in best or wall < best[ref][0]:
                    best[ref] = (wall, per_rule, stability)
    except RuntimeError as error:
        print(error, file=sys.stderr)
        return 1
    lines = []
    if args.compare:
        (base, new) = refs
        lines += [
            f"Cold builds side by side (`snakemake --cores {args.cores} {args.target}`, best of {args.repeat}, "
            "alternating):",
            "",
            "| ref | wall (s) | ratio to "
            + f"`{base}`"
            + " | job CPU time (s) | hbm_stage jobs (s) | stability logged in hbm_stage (s) | stability share "
            "of hbm_stage |",
            "|---|---:|---:|---:|---:|---:|---:|",
        ]
        for ref in refs:
            wall, per_rule, stability = best[ref]
            stage = per_rule.get("hbm_stage", (0, 0.0, 0.0))[1]
            cpu = sum(entry[2] for entry in per_rule.values())
            share = f"{100 * stability / stage:.0f} %" if stability and stage else "not logged"
            lines.append(
                f"| `{ref}` | {wall:.1f} | {wall / best[base][0]:.2f} | {cpu:.1f} | {stage:.1f} | "
                f"{stability:.1f} | {share} |"
            )
        lines.append("")
    for ref in refs:
        lines += rule_table(ref, args.cores, *best[ref][:2], args.target) + [""]
    return emit_report("\n".join(lines).rstrip(), args.output)


if __name__ == "__main__":
    sys.exit(main())
