"""Cost of each paper-figure task (Figs 2-11) after its imports, for one or several commits side by side.

Every ref is extracted (``cold_build.tracked_copy``) into a temporary directory. One measurement is
one fresh Python process with that tree's ``src`` on ``PYTHONPATH``, as a Snakemake job is: it imports
the figure tasks and reads the tree's configuration (timed apart, the "imports" row), then runs the
task ``paper_figNN`` once on the datasets of ``--results`` (CPU and wall time), writing the PDF and
PNG. The refs alternate figure by figure, ``--repeat`` times; the best time of each is kept. The
figures of the last ref are compared with those of the first: how far the axes moved in each format,
the share of PNG pixels that differ, whether the PDF is byte-identical; and in each ref, how far apart
the PDF and the PNG of one figure are laid out. The named inputs mirror the rules of workflow/rules/figures.smk.

Usage::

    python benchmarks/figure_cost.py --compare f7aecf3 HEAD [--repeat 3] [--results results]
    python benchmarks/figure_cost.py [--figures fig06 fig09]          # HEAD alone

``--results`` must hold the datasets the figures read (a finished build, or /work/baseline/results).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

from cold_build import tracked_copy
from timing import check_repeat, emit_report, timed

FIGURES = tuple(f"fig{n:02d}" for n in range(2, 12))


def rule_inputs(name: str, config: dict, results: Path) -> dict:
    """Named inputs of rule ``paper_<name>`` (as workflow/rules/figures.smk declares them) under ``results``."""
    stage = "hbm/stages/nnm1_stage{}.nc"
    comparison = str(results / "compare/nnm1_exact_vs_regularized.nc")
    if name == "fig02":
        exact, nnm1 = str(results / "exact/nnm1_two_impacts.nc"), str(results / stage.format(1))
        return {"exact": exact, "nnm1": nnm1, "comparison": comparison}
    if name in ("fig03", "fig04"):
        return {"comparison": comparison}
    if name == "fig05":
        return {"nnm1": str(results / "hbm/nnm1.nc"), "nnm2": str(results / "hbm/nnm2.nc")}
    if name == "fig06":
        return {"nnm2": str(results / "hbm/nnm2.nc")}
    spec = config["figures"][name]
    inputs = {"nnm1_stages": [str(results / stage.format(k)) for k in spec["nnm1_stages"]]}
    if config["figures"].get("overlay_exact", False):
        inputs["exact"] = str(results / "exact/nnm1.nc")
    if name in ("fig08", "fig09", "fig10"):
        inputs["nnm2"] = str(results / "hbm/nnm2.nc")
        inputs["bifurcated"] = [str(results / f"hbm/bifurcated/{b}.nc") for b in spec.get("bifurcated", [])]
    return inputs


def worker(name: str, tree: Path, results: Path, outputs: Path, configfile: Path | None = None) -> None:
    """In a fresh process: import the tree's figure tasks, then run ``paper_<name>``; print JSON.

    The JSON holds the times and the layout each format was saved with: the position of every
    axes (points from the lower left corner of the figure), keyed by the saved file's suffix.
    """

    def load():
        from matplotlib.figure import Figure

        from nnmstop.config import load_config
        from nnmstop.tasks.figures import TASKS

        return Figure, TASKS, load_config(configfile or tree / "config" / "config.yaml")

    (figure_class, tasks, config), import_cpu, _ = timed(load)
    layouts = {}
    savefig = figure_class.savefig

    def recording_savefig(fig, path, **kwargs):
        savefig(fig, path, **kwargs)
        size = np.tile(fig.get_size_inches() * 72.0, 2)
        layouts[Path(path).suffix.lstrip(".")] = [list(np.array(ax.get_position().bounds) * size) for ax in fig.axes]

    figure_class.savefig = recording_savefig
    task = tasks[f"paper_{name}"]
    files = {"pdf": str(outputs / f"{name}.pdf"), "png": str(outputs / f"{name}.png")}
    _, cpu, wall = timed(lambda: task(config, rule_inputs(name, config, results), files))
    print(json.dumps({"imports": import_cpu, "cpu": cpu, "wall": wall, "layouts": layouts}))


def measure(name: str, tree: Path, results: Path, outputs: Path, configfile: Path | None = None) -> dict:
    """Times and layouts of one figure task in a fresh process of the extracted tree ``tree``."""
    env = {**os.environ, "PYTHONPATH": str(tree / "src"), "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    command = [sys.executable, __file__, "--worker", name, "--tree", str(tree), "--results", str(results)]
    command += ["--configfile", str(configfile)] if configfile else []
    run = subprocess.run([*command, "--out", str(outputs)], env=env, capture_output=True, text=True, cwd=tree)
    if run.returncode != 0:
        raise RuntimeError(f"{name} failed in {tree}:\n{run.stderr[-3000:]}")
    return json.loads(run.stdout.strip().splitlines()[-1])


def differing_pixels(png_a: Path, png_b: Path) -> float:
    """Share of the pixels of two PNGs that differ (1.0 when their sizes differ)."""
    a, b = (np.asarray(Image.open(p).convert("RGB")) for p in (png_a, png_b))
    return 1.0 if a.shape != b.shape else float(np.mean(np.any(a != b, axis=2)))


def largest_shift(a: list, b: list) -> float:
    """Largest difference (points) between two layouts of the same axes; inf if they hold different axes."""
    a, b = np.asarray(a), np.asarray(b)
    return float(np.abs(a - b).max()) if a.shape == b.shape else float("inf")


def report(refs: list[str], figures: list[str], best: dict, outputs: list[Path], repeat: int) -> str:
    first, last = refs[0], refs[-1]
    head = " | ".join(f"`{r}` CPU (s) | `{r}` wall (s)" for r in refs)
    lines = [
        f"Figure tasks after their imports, fresh process per run, best of {repeat} (CPU and wall time):",
        "",
        f"| figure | {head} | CPU ratio `{last}` / `{first}` |",
        "|---|" + "---:|" * (2 * len(refs) + 1),
    ]
    totals = {r: [0.0, 0.0] for r in refs}
    for name in figures:
        cells = []
        for r in refs:
            cpu, wall = best[r, name]["cpu"], best[r, name]["wall"]
            totals[r][0] += cpu
            totals[r][1] += wall
            cells.append(f"{cpu:.2f} | {wall:.2f}")
        lines.append(f"| {name} | {' | '.join(cells)} | {best[last, name]['cpu'] / best[first, name]['cpu']:.2f} |")
    total_cells = " | ".join(f"**{totals[r][0]:.2f}** | **{totals[r][1]:.2f}**" for r in refs)
    lines.append(f"| all {len(figures)} | {total_cells} | **{totals[last][0] / totals[first][0]:.2f}** |")
    imports = " | ".join(f"{min(best[r, n]['imports'] for n in figures):.2f} | " for r in refs)
    lines.append(f"| imports of one job (CPU, not in the totals) | {imports} |")
    lines += [
        "",
        f"The figures of `{last}` against those of `{first}`: largest move of an axes (points) in the PDF and",
        "the PNG, share of PNG pixels that differ, byte-identical PDF; and how far apart the PDF and PNG of",
        "one figure are laid out, in each ref:",
        "",
        f"| figure | axes moved, PDF (pt) | axes moved, PNG (pt) | PNG pixels differing | PDF identical "
        f"| PDF vs PNG layout, `{first}` (pt) | PDF vs PNG layout, `{last}` (pt) |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for name in figures:
        old, new = best[first, name]["layouts"], best[last, name]["layouts"]
        pixels = differing_pixels(outputs[0] / f"{name}.png", outputs[-1] / f"{name}.png")
        same_pdf = (outputs[0] / f"{name}.pdf").read_bytes() == (outputs[-1] / f"{name}.pdf").read_bytes()
        lines.append(
            f"| {name} | {largest_shift(old['pdf'], new['pdf']):.2f} | {largest_shift(old['png'], new['png']):.2f} "
            f"| {100 * pixels:.1f} % | {'yes' if same_pdf else 'no'} | {largest_shift(old['pdf'], old['png']):.2f} "
            f"| {largest_shift(new['pdf'], new['png']):.2f} |"
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--compare", nargs="+", metavar="REF", default=["HEAD"], help="commits, first = reference")
    parser.add_argument("--figures", nargs="+", default=list(FIGURES), choices=FIGURES)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--results", type=Path, default=Path("results"), help="datasets the figures read")
    parser.add_argument("--output", type=Path, help="also write the report here")
    parser.add_argument(
        "--configfile", type=Path, help="the configuration of the --results build (default: each tree's)"
    )
    parser.add_argument("--worker", choices=FIGURES, help=argparse.SUPPRESS)
    parser.add_argument("--tree", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    results = args.results.resolve()
    configfile = args.configfile.resolve() if args.configfile else None
    if args.worker:
        worker(args.worker, args.tree, results, args.out, configfile)
        return 0
    check_repeat(args.repeat)
    if not (results / "hbm" / "nnm2.nc").is_file():
        raise ValueError(f"--results {results} holds no hbm/nnm2.nc: give a results tree of a finished build")
    with tempfile.TemporaryDirectory(prefix="nnmstop-figcost-") as tmp:
        trees, outputs = [], []
        for i, ref in enumerate(args.compare):
            trees.append(Path(tmp) / f"tree{i}")
            outputs.append(Path(tmp) / f"figures{i}")
            trees[-1].mkdir()
            outputs[-1].mkdir()
            tracked_copy(trees[-1], ref)
        best: dict = {}
        for _ in range(args.repeat):
            for name in args.figures:
                for ref, tree, out in zip(args.compare, trees, outputs):
                    times = measure(name, tree, results, out, configfile)
                    kept = best.setdefault((ref, name), times)
                    best[ref, name] = {key: min(kept[key], times[key]) for key in ("imports", "cpu", "wall")}
                    best[ref, name]["layouts"] = times["layouts"]
        return emit_report(report(args.compare, args.figures, best, outputs, args.repeat), args.output)


if __name__ == "__main__":
    sys.exit(main())
