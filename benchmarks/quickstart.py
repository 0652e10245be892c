"""Time the quick start of README as a new user runs it: install, build every figure, run the tests.

Clones the repository into a fresh directory (the committed tree of ``HEAD`` with its history, as a user
has it: some tests of the benchmark scripts build older commits) and runs there, one after the other, the
steps of README's two set-up commands:

* ``install`` (with ``--install``): a fresh virtual environment of this Python, then
  ``pip install -r environment.lock && pip install --no-deps -e .`` (network and cache dependent);
* ``build``: ``snakemake --cores N`` (every figure of the paper, the datasets behind them);
* ``tests``: ``python -m pytest`` (the whole suite, as CI runs it).

Without ``--install`` the steps run in the current environment with the extracted tree's ``src`` first
on ``PYTHONPATH``. The report (``--output``, by default ``benchmarks/quickstart.md``) gives each step's
wall time and exit status, with the command, commit, machine and load (``timing.run_header``);
``--readme`` writes the times of the steps that succeeded into README.md between its
``quickstart-times`` markers (from the run, or with ``--readme --no-run`` from the committed report);
a test checks that README quotes the committed report.

Usage::

    python benchmarks/quickstart.py [--install] [--cores 2] [--readme]
    python benchmarks/quickstart.py --readme --no-run          # README quotes benchmarks/quickstart.md
    python benchmarks/quickstart.py --tiny --output /tmp/quickstart.md   # seconds: one dataset, one test file
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
from pathlib import Path

from cold_build import REPO
from timing import emit_report

__all__ = ["quickstart_steps", "readme_times", "report_readme_line", "write_readme_line"]

TINY_CONFIG = REPO / "tests" / "data" / "small_config.yaml"
README_BEGIN = "<!-- quickstart-times: written by `python benchmarks/quickstart.py --readme` -->"
README_END = "<!-- quickstart-times end -->"


def quickstart_steps(tree: Path, cores: int, install: bool, tiny: bool) -> list:
    """``(name, command, environment)`` of each step, run in ``tree``."""
    env = {**os.environ, "PYTHONPATH": str(tree / "src")}
    python = sys.executable
    steps = []
    if install:
        venv = tree / ".venv"
        python = str(venv / "bin" / "python")
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
        steps.append(("install", f"{sys.executable} -m venv .venv && pip install -r environment.lock && "
                      "pip install --no-deps -e .", env))  # fmt: skip
    build = f"{python} -m snakemake --cores {cores}"
    tests = f"{python} -m pytest -q -p no:cacheprovider"
    if tiny:
        build += f" results/exact/nnm1_two_impacts.nc --configfile {TINY_CONFIG}"  # --configfile takes a list
        tests += " tests/test_fourier.py"
    steps += [("build", build, env), ("tests", tests, env)]
    return steps


def run_steps(steps: list, tree: Path) -> list:
    """Run each step in ``tree``; ``(name, command, seconds, exit status)``, stopping after a failure."""
    done = []
    for name, command, env in steps:
        started = time.perf_counter()
        run = subprocess.run(command, shell=True, cwd=tree, env=env, capture_output=True)
        shown = command.replace(str(tree), ".").replace(sys.executable, "python")
        done.append((name, shown, time.perf_counter() - started, run.returncode))
        print(f"{name}: {done[-1][2]:.0f} s, exit {run.returncode}", file=sys.stderr, flush=True)
        if run.returncode != 0:  # the end of its output says why (pytest's summary is on stdout)
            print(
                run.stdout.decode(errors="replace")[-5000:],
                run.stderr.decode(errors="replace")[-3000:],
                file=sys.stderr,
            )
            break
    return done


def minutes(seconds: float) -> str:
    """``seconds`` as README quotes a time: whole minutes, or seconds below two minutes."""
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.0f} min"


LABELS = {"install": "installing", "build": "building every figure", "tests": "the tests"}


def readme_times(done: list, cpus: int | None = None) -> str:
    """The sentence README quotes between its markers: the time of each step that succeeded."""
    parts = [f"{LABELS[name]} {minutes(seconds)}" for name, _, seconds, status in done if status == 0]
    return f"Measured on {cpus or os.cpu_count()} shared cores (`benchmarks/quickstart.md`): " + ", ".join(parts) + "."


def report_readme_line(report: str) -> str:
    """The sentence for README, from the table of a report of this script (steps that exited 0)."""
    cpus = re.search(r"(\d+) logical CPUs", report)
    rows = re.findall(r"^\| (install|build|tests) \| `[^`]*` \| ([0-9]+) (s|min) \| (\d+) \|$", report, re.MULTILINE)
    if not cpus or not rows:
        raise ValueError("not a report of benchmarks/quickstart.py (no machine line or no step rows)")
    done = [(name, "", float(value) * (60 if unit == "min" else 1), int(status)) for name, value, unit, status in rows]
    return readme_times(done, int(cpus[1]))


def write_readme_line(line: str, readme: Path = REPO / "README.md") -> None:
    """Put ``line`` between README's ``quickstart-times`` markers."""
    pattern = re.compile(re.escape(README_BEGIN) + r"\n.*?\n" + re.escape(README_END), re.DOTALL)
    text = readme.read_text()
    if not pattern.search(text):
        raise ValueError(f"{readme} has no {README_BEGIN} ... {README_END} block")
    readme.write_text(pattern.sub(lambda _: f"{README_BEGIN}\n{line}\n{README_END}", text))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--install", action="store_true", help="time the installation into a fresh venv too")
    parser.add_argument("--tiny", action="store_true", help="one dataset of the small configuration, one test file")
    parser.add_argument("--output", type=Path, default=Path(__file__).with_name("quickstart.md"))
    parser.add_argument("--readme", action="store_true", help="write the measured times into README.md")
    parser.add_argument("--no-run", action="store_true", help="with --readme: quote the report --output as it is")
    args = parser.parse_args(argv)
    if args.no_run:
        if not args.readme:
            parser.error("--no-run goes with --readme")
        write_readme_line(report_readme_line(args.output.read_text()))
        return 0
    tree = Path(tempfile.mkdtemp(prefix="nnmstop-quickstart-"))
    try:
        subprocess.run(["git", "clone", "--quiet", str(REPO), str(tree)], check=True)
        done = run_steps(quickstart_steps(tree, args.cores, args.install, args.tiny), tree)
    finally:
        shutil.rmtree(tree, ignore_errors=True)
    lines = [
        "# The quick start, timed (`python benchmarks/quickstart.py`)",
        "",
        "Each step of README's set-up commands in a fresh clone of the repository, one after the other.",
        "",
        "| step | command | wall time | exit status |",
        "|---|---|---:|---:|",
        *(f"| {name} | `{command}` | {minutes(seconds)} | {status} |" for name, command, seconds, status in done),
    ]
    failed = any(status != 0 for *_, status in done)
    emit_report("\n".join(lines), args.output)
    if args.readme and not failed:
        write_readme_line(readme_times(done))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
