"""Compute time of the exact and comparison tasks of two commits, in short alternating slices.

On a shared machine the CPU time of a 15 s task moves by +-20 % with what runs beside it
(``exact_build.py`` times whole tasks). This script times the computations alone, without the
interpreter start-up, in slices of a second or two, alternating the two commits many times
(A, B, A, B, ...), and reports the fastest and the median slice of each: the fastest slices
are the ones that ran with the least contention. Each slice runs in a fresh interpreter with
``PYTHONPATH`` set to the commit's ``src`` and times (CPU, ``time.process_time``)

* ``two_impacts``: the two-impact family (``follow_two_impact_family``), as in ``exact_two_impacts``;
* ``branch``: the continuation of the exact NNM1 (``follow_branch``) up to ``--points`` orbits,
  and ``dataset``: its dataset with the Floquet variables (``exact_branch_dataset``);
* ``compare``: the exact/regularized comparison (``comparison_dataset``) at ``--energies``
  energies, on the regularized NNM1 stage 1 given by ``--nnm1-stage1``.

It also says whether both commits computed the same numbers (every variable of the three
datasets, bit for bit). Usage::

    python benchmarks/exact_slices.py --compare main HEAD --nnm1-stage1 results/hbm/stages/nnm1_stage1.nc
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cold_build import tracked_copy  # noqa: E402

#: Run in each tree: prints the CPU time of each part and a digest of the numbers, as JSON.
SLICE = """
import dataclasses, hashlib, json, sys, time
import numpy as np
from nnmstop.compare.dataset import comparison_dataset
from nnmstop.config import load_config
from nnmstop.exact.dataset import exact_branch_dataset, two_impact_dataset, two_impact_unknowns
from nnmstop.exact.family import FamilySettings, follow_branch, follow_two_impact_family
from nnmstop.models.two_dof import ModelParameters
from nnmstop.netcdf import read_dataset

points, energies, stage1, config_file = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3], sys.argv[4]
config = load_config(config_file)
params = ModelParameters.from_config(config["model"])
settings = dataclasses.replace(FamilySettings.from_config(config["exact_multi"]), max_points=points)
times, digest = {}, hashlib.sha256()


def timed(name, compute):
    start = time.process_time()
    result = compute()
    times[name] = time.process_time() - start
    return result


def add(ds):
    for name in sorted(ds.variables):
        if ds[name].dtype.kind in "fiub":
            digest.update(np.ascontiguousarray(ds[name].values).tobytes())


family = timed("two_impacts", lambda: follow_two_impact_family(params, config["exact"]["step"],
                                                                 config["exact"]["max_points"]))
two = two_impact_dataset(family)
y = two_impact_unknowns(two)
segments = timed("branch", lambda: follow_branch(params, "FR", y[-1], y[-1] - y[-2], settings))
add(two)
add(timed("dataset", lambda: exact_branch_dataset(two, segments, params)))
branch = read_dataset(stage1)
spec = config["compare"]
add(timed("compare", lambda: comparison_dataset(two, branch, count=energies, phase_samples=spec["phase_samples"])))
print(json.dumps({"times": times, "digest": digest.hexdigest()}))
"""


def run_slice(tree: Path, points: int, energies: int, stage1: Path, configfile: Path | None = None) -> dict:
    """One slice in ``tree``: ``{"times": {part: cpu seconds}, "digest": str}``.

    ``configfile`` replaces the tree's own ``config/config.yaml`` (it must be the one ``stage1`` was built with).
    """
    env = {**os.environ, "PYTHONPATH": str(tree / "src"), "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    config = str(Path(configfile).resolve()) if configfile else "config/config.yaml"
    command = [sys.executable, "-c", SLICE, str(points), str(energies), str(stage1.resolve()), config]
    out = subprocess.run(command, cwd=tree, env=env, check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--compare", nargs=2, metavar=("A", "B"), default=("main", "HEAD"))
    parser.add_argument("--nnm1-stage1", type=Path, required=True, help="regularized NNM1 stage-1 dataset")
    parser.add_argument("--slices", type=int, default=8, help="slices per commit (alternating)")
    parser.add_argument("--points", type=int, default=800, help="orbits of the exact branch per slice")
    parser.add_argument("--energies", type=int, default=10, help="compared energies per slice")
    parser.add_argument("--configfile", type=Path, help="the configuration --nnm1-stage1 was built with")
    args = parser.parse_args(argv)
    for name in ("slices", "points", "energies"):
        if getattr(args, name) < 2:
            raise ValueError(f"--{name} must be >= 2, got {getattr(args, name)}")
    if not args.nnm1_stage1.is_file():
        raise ValueError(f"--nnm1-stage1 {args.nnm1_stage1} is not a file")
    trees, results = {}, {ref: [] for ref in args.compare}
    try:
        for ref in args.compare:
            trees[ref] = Path(tempfile.mkdtemp(prefix="nnmstop-slices-"))
            tracked_copy(trees[ref], ref)
        for _ in range(args.slices):
            for ref in args.compare:
                results[ref].append(
                    run_slice(trees[ref], args.points, args.energies, args.nnm1_stage1, args.configfile)
                )
    finally:
        for tree in trees.values():
            shutil.rmtree(tree, ignore_errors=True)
    a, b = args.compare
    print(f"{args.slices} slices per commit, {args.points} exact orbits, {args.energies} compared energies")
    print(f"| part | {a} fastest [s] | {b} fastest [s] | ratio | {a} median [s] | {b} median [s] | ratio |")
    print("|---|---|---|---|---|---|---|")
    for part in results[a][0]["times"]:
        ta = [r["times"][part] for r in results[a]]
        tb = [r["times"][part] for r in results[b]]
        fa, fb, ma, mb = min(ta), min(tb), statistics.median(ta), statistics.median(tb)
        print(f"| {part} | {fa:.2f} | {fb:.2f} | {fb / fa:.2f} | {ma:.2f} | {mb:.2f} | {mb / ma:.2f} |")
    digests = {r["digest"] for ref in args.compare for r in results[ref]}
    print(f"same numbers in every slice of both commits: {len(digests) == 1}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
