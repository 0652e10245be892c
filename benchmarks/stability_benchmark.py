"""Cost per point of the two stability methods, side by side in one run.

Reads the orbits of built branch datasets (default: ``results/hbm/nnm1.nc``,
``results/hbm/nnm2.nc`` and the switched branches; build them first with
``snakemake --cores 2 results/hbm/nnm1.nc ...``), takes every ``--stride``-th point,
and times on the same points, alternately, Hill's method
(:func:`nnmstop.hbm.stability.branch_hill`) and the monodromy
(:func:`nnmstop.hbm.monodromy.branch_monodromy`, settings from ``config/config.yaml``).
Also reports how many verdicts each resolves and whether they agree where both do, and lists
each point where they differ (energy, Hill's largest multiplier, the monodromy's invariant
``s = mu + 1/mu``, its reason code and whether the orbit was refined, the orbit's time residual).

Usage::

    OPENBLAS_NUM_THREADS=1 python benchmarks/stability_benchmark.py [--stride 4] [--repeat 3] \
        [--output FILE] [DATASET ...]

Wall times on a shared machine are noisy: compare the two columns of one run.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from branch_orbits import branch_orbits
from nnmstop.config import load_config
from nnmstop.hbm.monodromy import MonodromySettings, branch_monodromy
from nnmstop.hbm.stability import branch_hill
from timing import best_time, emit_report

DEFAULT_DATASETS = [
    "results/hbm/nnm1.nc",
    "results/hbm/nnm2.nc",
    "results/hbm/bifurcated/nnm1_3to1.nc",
    "results/hbm/bifurcated/nnm1_5to1.nc",
]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="*", default=DEFAULT_DATASETS)
    parser.add_argument("--config", default="config/config.yaml")
    parser.add_argument("--stride", type=int, default=4, help="every stride-th point of each dataset")
    parser.add_argument("--repeat", type=int, default=3, help="best of this many runs per method")
    parser.add_argument("--output", type=Path, help="also write the Markdown table here")
    args = parser.parse_args(argv)
    if args.stride < 1 or args.repeat < 1:
        raise ValueError(f"--stride and --repeat must be >= 1, got {args.stride}, {args.repeat}")
    config = load_config(args.config)
    settings = MonodromySettings.from_config(config.get("stability", {}))
    lines = [
        f"Stability cost per point, Hill's method vs monodromy (steps {settings.steps}..{settings.max_steps}), "
        f"every {args.stride}th point, best of {args.repeat}:",
        "",
        "| dataset | points | Hill (ms/point) | monodromy (ms/point) | speed-up | resolved Hill | resolved "
        "monodromy | verdicts differ where both resolved |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    differences = []
    for path, system, U, residual in branch_orbits(args.datasets, config, args.stride):
        hill, t_hill = best_time(lambda: branch_hill(system, U), args.repeat)  # noqa: B023 (called at once)
        mono, t_mono = best_time(lambda: branch_monodromy(system, U, settings, time_residual=residual), args.repeat)  # noqa: B023 (called at once)
        both = hill.resolved & mono.resolved
        differing = np.flatnonzero(both & (hill.stable != mono.stable))
        n = len(U)
        lines.append(
            f"| {path.name} | {n} | {1e3 * t_hill / n:.1f} | {1e3 * t_mono / n:.1f} | {t_hill / t_mono:.1f}x | "
            f"{int(hill.resolved.sum())} | {int(mono.resolved.sum())} | {differing.size} |"
        )
        for i in differing:
            differences.append(
                f"- {path.name}: E = {system.diagnostics(U[i])['energy']:.6g}, Hill max |mu| = "
                f"{hill.max_multiplier[i]:.4g} ({'stable' if hill.stable[i] else 'unstable'}), monodromy "
                f"s = {mono.invariant[i]:.6g} ({'stable' if mono.stable[i] else 'unstable'}, reason "
                f"{int(mono.reason[i])}, refined {'yes' if mono.refined[i] else 'no'}), time residual {residual[i]:.2g}"
            )
    if differences:
        lines += ["", "Verdicts that differ where both methods resolve:", *differences]
    return emit_report("\n".join(lines), args.output)


if __name__ == "__main__":
    sys.exit(main())
