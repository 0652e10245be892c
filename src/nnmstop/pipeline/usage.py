"""The CPU time and memory of a build's tasks, read from their logs.

Every task ends its log with one line (:func:`nnmstop.pipeline.run.run_task`)::

    task hbm_stage ran in the warm worker: W s wall, C s CPU (user U s, system S s), M MB peak resident;
        finished

(one line in the log)

A task run by the warm worker works in a fork of the worker, outside the job's process tree:
``/usr/bin/time snakemake ...`` and Snakemake's ``benchmark:`` files do not see its CPU time,
but this line does. ``python -m nnmstop.pipeline.usage [LOGS]`` sums the lines of every log under
``LOGS`` (default ``logs``), per rule and in total, separately for tasks run in the worker and in
their own process (whose CPU time includes the interpreter's start and imports).
"""

from __future__ import annotations

import argparse
import re
import sys
from collections import defaultdict
from pathlib import Path

__all__ = ["TaskUsage", "read_usage", "summarize", "main"]

_LINE = re.compile(
    r"task (?P<task>\w+) ran (?P<where>in the warm worker|in its own process): (?P<wall>[0-9.]+) s wall, "
    r"(?P<cpu>[0-9.]+) s CPU \(user (?P<user>[0-9.]+) s, system (?P<system>[0-9.]+) s\), "
    r"(?P<memory>[0-9.]+) MB peak resident; (?P<outcome>.*)$"
)


class TaskUsage(dict):
    """One task's line: ``task``, ``where``, ``wall``, ``cpu``, ``user``, ``system``, ``memory`` (MB),
    ``outcome`` and the ``log`` it came from."""


def read_usage(logs) -> list[TaskUsage]:
    """The cost lines of every ``*.log`` under ``logs`` (a folder), in path order."""
    found = []
    for path in sorted(Path(logs).rglob("*.log")):
        for line in path.read_text(errors="replace").splitlines():
            match = _LINE.search(line)
            if match:
                usage = TaskUsage(match.groupdict(), log=str(path))
                for key in ("wall", "cpu", "user", "system", "memory"):
                    usage[key] = float(usage[key])
                found.append(usage)
    return found


def summarize(usages: list[TaskUsage]) -> str:
    """A table per rule (jobs, CPU time in the worker and in own processes, largest peak memory) and the totals."""
    rows = defaultdict(lambda: {"jobs": 0, "worker": 0.0, "own": 0.0, "memory": 0.0})
    for usage in usages:
        row = rows[usage["task"]]
        row["jobs"] += 1
        row["worker" if usage["where"] == "in the warm worker" else "own"] += usage["cpu"]
        row["memory"] = max(row["memory"], usage["memory"])
    lines = [
        f"{'task':32s} {'jobs':>5s} {'CPU in worker (s)':>18s} {'CPU own process (s)':>20s} {'peak MB':>8s}",
    ]
    for task in sorted(rows):
        row = rows[task]
        lines.append(f"{task:32s} {row['jobs']:5d} {row['worker']:18.2f} {row['own']:20.2f} {row['memory']:8.0f}")
    worker = sum(r["worker"] for r in rows.values())
    own = sum(r["own"] for r in rows.values())
    lines.append(
        f"{'total':32s} {sum(r['jobs'] for r in rows.values()):5d} {worker:18.2f} {own:20.2f}"
        f"   (all tasks: {worker + own:.2f} s CPU)"
    )
    return "\n".join(lines)


def main(argv=None) -> int:
    """``python -m nnmstop.pipeline.usage [LOGS]``: print the table of :func:`summarize`."""
    parser = argparse.ArgumentParser(prog="python -m nnmstop.pipeline.usage", description=__doc__.splitlines()[0])
    parser.add_argument("logs", nargs="?", default="logs", help="folder of the build's logs (default: logs)")
    args = parser.parse_args(argv)
    if not Path(args.logs).is_dir():
        print(f"error: no log folder {args.logs!r} (the build writes its logs under logs/)", file=sys.stderr)
        return 2
    usages = read_usage(args.logs)
    if not usages:
        print(f"error: no task cost line in the logs under {args.logs}", file=sys.stderr)
        return 1
    print(summarize(usages))
    return 0


if __name__ == "__main__":
    sys.exit(main())
