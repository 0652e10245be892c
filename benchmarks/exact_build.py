"""Time the exact-orbit tasks (``exact_two_impacts``, ``exact_nnm1``) of two commits side by side.

Extracts each committed tree into a fresh temporary directory (as ``cold_build.py`` does),
runs the two tasks through ``python -m nnmstop.pipeline.run`` with ``PYTHONPATH`` set to that
tree's ``src``, alternately ``--repeat`` times (A, B, A, B, ...), and reports the best wall
and CPU (user + system) time of each task with the ratio B/A. The CPU time is the steadier
figure on a shared machine; the wall time is what the build waits for. Both trees read
the configuration of their own commit. It also says whether the two commits wrote the same
data (``nnmstop.pipeline.verify.data_digest``). With ``--nnm1-stage1`` (a regularized NNM1 stage-1
dataset, e.g. ``results/hbm/stages/nnm1_stage1.nc`` of a build) the task ``compare_nnm1`` is
timed too, on that file and the tree's own two-impact family. Each time includes the task's
interpreter and import start-up, about 1-2 s (the ``start-up`` line of the table: ``python -m
nnmstop.pipeline.run --help``, which imports every task module as each task does, in the tree).

Usage::

    python benchmarks/exact_build.py --compare main HEAD [--repeat 2] [--nnm1-stage1 PATH]
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cold_build import tracked_copy  # noqa: E402

TASKS = (
    ("exact_two_impacts", [], "two_impacts.nc"),
    ("exact_nnm1", ["--input", "two_impacts=two_impacts.nc"], "nnm1.nc"),
)


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def tasks(nnm1_stage1: Path | None, only: tuple | None = None) -> tuple:
    """``(task, extra arguments, output)`` of the timed tasks, ``compare_nnm1`` when a stage-1 file is given.

    ``only`` keeps the tasks it names (and those they read from).
    """
    chosen = TASKS
    if nnm1_stage1 is not None:
        compare = ["--input", "exact=two_impacts.nc", "--input", f"nnm1={nnm1_stage1.resolve()}"]
        chosen = (*TASKS, ("compare_nnm1", compare, "compare.nc"))
    if only is None:
        return chosen
    return tuple(t for t in chosen if t[0] in only or t[0] == "exact_two_impacts")


def _timed(command: list, tree: Path, env: dict) -> tuple:
    cpu0, wall0 = _children_cpu(), time.perf_counter()
    subprocess.run(command, cwd=tree, env=env, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - wall0, _children_cpu() - cpu0


def run_tasks(tree: Path, nnm1_stage1: Path | None = None, configfile: Path | None = None, only=None) -> dict:
    """Run the tasks in ``tree``; ``{task: (wall seconds, cpu seconds)}``, and the ``start-up`` alone.

    ``configfile`` replaces the tree's own ``config/config.yaml``.
    """
    env = {**os.environ, "PYTHONPATH": str(tree / "src"), "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    times = {"start-up": _timed([sys.executable, "-m", "nnmstop.pipeline.run", "--help"], tree, env)}
    config = ["--config", str(Path(configfile).resolve())] if configfile else []
    for task, extra, output in tasks(nnm1_stage1, only):
        command = [sys.executable, "-m", "nnmstop.pipeline.run", task, *config, *extra, "--output", f"dataset={output}"]
        times[task] = _timed([*command, "--log", "task.log"], tree, env)
    return times


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--compare", nargs=2, metavar=("A", "B"), default=("main", "HEAD"))
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--nnm1-stage1", type=Path, default=None, help="time compare_nnm1 on this stage-1 dataset")
    parser.add_argument("--configfile", type=Path, help="a configuration to run with instead of each tree's own")
    parser.add_argument("--tasks", nargs="+", choices=("exact_two_impacts", "exact_nnm1", "compare_nnm1"))
    args = parser.parse_args(argv)
    if args.repeat < 1:
        raise ValueError(f"--repeat must be >= 1, got {args.repeat}")
    if args.nnm1_stage1 is not None and not args.nnm1_stage1.is_file():
        raise ValueError(f"--nnm1-stage1 {args.nnm1_stage1} is not a file")
    trees = {}
    try:
        for ref in args.compare:
            trees[ref] = Path(tempfile.mkdtemp(prefix="nnmstop-exact-"))
            tracked_copy(trees[ref], ref)
        best = {ref: {} for ref in args.compare}
        for _ in range(args.repeat):
            for ref in args.compare:
                for task, (wall, cpu) in run_tasks(trees[ref], args.nnm1_stage1, args.configfile, args.tasks).items():
                    old = best[ref].get(task, (float("inf"), float("inf")))
                    best[ref][task] = (min(old[0], wall), min(old[1], cpu))
        a, b = args.compare
        from nnmstop.pipeline.verify import data_digest

        print(f"| task | {a} wall [s] | {b} wall [s] | ratio | {a} CPU [s] | {b} CPU [s] | ratio | same data |")
        print("|---|---|---|---|---|---|---|---|")
        for task, _, output in (("start-up", None, None), *tasks(args.nnm1_stage1, args.tasks)):
            (wa, ca), (wb, cb) = best[a][task], best[b][task]
            same = "" if output is None else data_digest(trees[a] / output) == data_digest(trees[b] / output)
            print(f"| {task} | {wa:.1f} | {wb:.1f} | {wb / wa:.2f} | {ca:.1f} | {cb:.1f} | {cb / ca:.2f} | {same} |")
    finally:
        for tree in trees.values():
            shutil.rmtree(tree, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
