"""Cost of the monodromy stability of built branch datasets for two commits, side by side in one run.

For each commit the package (its ``src``) is extracted into a temporary directory; a fresh
interpreter with that package on ``PYTHONPATH`` times
:func:`nnmstop.hbm.monodromy.branch_monodromy` (settings from ``config/config.yaml`` of the
working tree, refinement included) on the orbits of each dataset: what the ``hbm_stage`` jobs
log as "stability of N points in X s". The commits run alternately (A, B, A, B, ...), best of
``--repeat``, CPU time (``time.process_time``, robust on a shared machine) and wall time; the
last column says whether the two commits give the same ``stable`` and ``stability_reason`` on
every point.

Usage::

    OPENBLAS_NUM_THREADS=1 python benchmarks/stability_compare.py --compare f7aecf3 HEAD \
        [--repeat 2] [--output FILE] results/hbm/stages/*.nc
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from cold_build import REPO, tracked_copy
from timing import check_repeat, emit_report

# Run in the interpreter of one commit: times branch_monodromy per dataset, prints JSON.
_CHILD = """
import json, sys
sys.path.insert(0, {benchmarks!r})
from branch_orbits import branch_orbits
import yaml
from nnmstop.hbm.monodromy import MonodromySettings, branch_monodromy
from timing import timed
# read without validation: each commit's schema may name keys the other's does not (settings take their own)
config = yaml.safe_load(open({config!r}))
settings = MonodromySettings.from_config(config.get("stability", {{}}))
out = {{}}
for path, system, U, residual in branch_orbits({datasets!r}, config):
    result, cpu, wall = timed(lambda: branch_monodromy(system, U, settings, time_residual=residual))
    out[path.name] = dict(points=len(U), cpu=cpu, wall=wall, refined=int(result.refined.sum()),
                          stable=result.stable.astype(int).tolist(), reason=result.reason.astype(int).tolist(),
                          invariant=result.invariant.tolist())
print(json.dumps(out))
"""


def time_commit(source: Path, datasets, config: Path) -> dict:
    """Per-dataset timings of one run of the package in ``source`` (a fresh interpreter)."""
    code = _CHILD.format(benchmarks=str(REPO / "benchmarks"), config=str(config), datasets=[str(d) for d in datasets])
    env = dict(os.environ, PYTHONPATH=str(source / "src"), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    return json.loads(run.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="+", type=Path)
    parser.add_argument("--compare", nargs=2, metavar=("A", "B"), required=True, help="two git refs")
    parser.add_argument("--config", type=Path, default=REPO / "config/config.yaml")
    parser.add_argument("--repeat", type=int, default=2, help="best of this many runs per commit")
    parser.add_argument("--output", type=Path, help="also write the Markdown table here")
    args = parser.parse_args(argv)
    check_repeat(args.repeat)
    datasets = [d.resolve() for d in args.datasets]
    missing = [str(d) for d in datasets if not d.exists()]
    if missing:
        raise ValueError(f"datasets not built: {', '.join(missing)}")
    with tempfile.TemporaryDirectory(prefix="nnmstop-stability-") as tmp:
        sources = {}
        for ref in args.compare:
            if ref in sources:  # a ref against itself: the noise of the measurement
                continue
            sources[ref] = Path(tmp) / ref.replace("/", "_")
            sources[ref].mkdir()
            tracked_copy(sources[ref], ref)
        best, last = {}, {}
        for _ in range(args.repeat):
            for ref in args.compare:
                last[ref] = time_commit(sources[ref], datasets, args.config.resolve())
                for name, row in last[ref].items():
                    old = best.setdefault(ref, {}).get(name, (float("inf"), float("inf")))
                    best[ref][name] = (min(old[0], row["cpu"]), min(old[1], row["wall"]))
    a, b = args.compare
    lines = [
        f"Monodromy stability (branch_monodromy, refinement included) of `{a}` and `{b}`, best of {args.repeat}, "
        "alternating, CPU time (wall time in parentheses):",
        "",
        f"| dataset | points | refined | `{a}` (s) | `{b}` (s) | CPU ratio | same verdicts and reasons | "
        "largest change of floquet_invariant |",
        "|---|---:|---:|---:|---:|---:|---|---:|",
    ]
    total = {a: [0.0, 0.0], b: [0.0, 0.0]}
    for name, row in last[a].items():
        for ref in (a, b):
            total[ref] = [total[ref][0] + best[ref][name][0], total[ref][1] + best[ref][name][1]]
        same = row["stable"] == last[b][name]["stable"] and row["reason"] == last[b][name]["reason"]
        change = max((abs(x - y) for x, y in zip(row["invariant"], last[b][name]["invariant"])), default=0.0)
        lines.append(
            f"| {name} | {row['points']} | {row['refined']} | {best[a][name][0]:.2f} ({best[a][name][1]:.2f}) | "
            f"{best[b][name][0]:.2f} ({best[b][name][1]:.2f}) | {best[b][name][0] / best[a][name][0]:.2f} | "
            f"{'yes' if same else 'NO'} | {change:.1e} |"
        )
    lines.append(
        f"| total | | | {total[a][0]:.2f} ({total[a][1]:.2f}) | {total[b][0]:.2f} ({total[b][1]:.2f}) | "
        f"{total[b][0] / total[a][0]:.2f} | | |"
    )
    return emit_report("\n".join(lines), args.output)


if __name__ == "__main__":
    sys.exit(main())
