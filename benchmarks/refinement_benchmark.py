"""Cost of the shooting refinement of the monodromy verdicts, side by side in one run.

For each built branch dataset (default: ``results/hbm/nnm1.nc``, ``results/hbm/nnm2.nc`` and the
switched branches; the per-stage datasets ``results/hbm/stages/*.nc`` are what the ``hbm_stage``
jobs compute) the monodromy stability of all its orbits (:func:`nnmstop.monodromy.branch_monodromy`,
settings from ``config/config.yaml``) with ``refine: false`` and with ``refine: true``,
alternately, best of ``--repeat``: CPU time (``time.process_time``, robust on a shared machine)
and wall time, the time added per refined orbit, the verdicts resolved, the reasons, and the
change of frequency and energy from the HBM orbits to the refined ones.

Usage::

    OPENBLAS_NUM_THREADS=1 python benchmarks/refinement_benchmark.py [--repeat 3] [--output FILE] [DATASET ...]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

from branch_orbits import branch_orbits
from nnmstop.catalogue import kind
from nnmstop.config import load_config
from nnmstop.hbm.monodromy import MonodromySettings, branch_monodromy
from timing import check_repeat, emit_report, timed

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
    parser.add_argument("--repeat", type=int, default=3, help="best of this many runs per setting")
    parser.add_argument("--output", type=Path, help="also write the Markdown table here")
    args = parser.parse_args(argv)
    check_repeat(args.repeat)
    config = load_config(args.config)
    refined_settings = dataclasses.replace(MonodromySettings.from_config(config.get("stability", {})), refine=True)
    plain_settings = dataclasses.replace(refined_settings, refine=False)
    lines = [
        f"Monodromy stability without and with the shooting refinement (refine_steps {refined_settings.refine_steps}), "
        f"best of {args.repeat}, CPU time (wall time in parentheses):",
        "",
        "| dataset | points | resolved without | refined | resolved with | reasons with (code: count) | "
        "CPU without (s) | CPU with (s) | added CPU per refined orbit (ms) | max abs frequency change | "
        "max abs energy change |",
        "|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|",
    ]
    for path, system, U, residual in branch_orbits(args.datasets, config):
        best = {"plain": (np.inf, np.inf), "refined": (np.inf, np.inf)}
        results = {}
        for _ in range(args.repeat):
            for key, settings in (("plain", plain_settings), ("refined", refined_settings)):
                # called at once, inside this iteration: the loop variables are the ones meant
                result, cpu, wall = timed(lambda: branch_monodromy(system, U, settings, time_residual=residual))  # noqa: B023
                results[key] = result
                best[key] = (min(best[key][0], cpu), min(best[key][1], wall))
        plain, refined = results["plain"], results["refined"]
        count = int(refined.refined.sum())
        added = f"{1e3 * (best['refined'][0] - best['plain'][0]) / count:.1f}" if count else "-"
        meanings = kind("nnm_branch")["stability_reason"].flags
        reasons = ", ".join(f"{code} {meanings[code]}: {n}" for code, n in enumerate(np.bincount(refined.reason)) if n)
        converged = refined.refined & (refined.reason != 4)
        df = float(np.abs(refined.refined_frequency_change[converged]).max()) if converged.any() else 0.0
        de = float(np.abs(refined.refined_energy_change[converged]).max()) if converged.any() else 0.0
        lines.append(
            f"| {path.name} | {len(U)} | {int(plain.resolved.sum())} | {count} | {int(refined.resolved.sum())} | "
            f"{reasons} | {best['plain'][0]:.2f} ({best['plain'][1]:.2f}) | {best['refined'][0]:.2f} "
            f"({best['refined'][1]:.2f}) | {added} | {df:.1e} | {de:.1e} |"
        )
    return emit_report("\n".join(lines), args.output)


if __name__ == "__main__":
    sys.exit(main())
