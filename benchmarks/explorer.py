"""Size and first render time of the explorer page (issue 24: at most ~10 MB, first render under 2 s).

    snakemake --cores 2 explorer
    python benchmarks/explorer.py --page dist/explorer.html --repeat 5 --output benchmarks/explorer.md

Opens the page ``--repeat`` times in headless Chromium (a fresh profile each time, so nothing is cached)
at 1280 x 800 and reads the page's own clock (``window.explorer.timings``, milliseconds since the
navigation started): script start (HTML and the inlined plotly.js parsed), data decoded, frequency-energy
plot drawn, and ready (every view drawn for the first selected orbit: the first render), and the CPU time
the renderer spent until ready (Chromium's performance metrics; on a shared machine the wall times grow with
the load, the CPU times hardly). Reports the median and the best, the page's size by part, the commit,
the machine and its load.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import statistics
import subprocess
import sys
from pathlib import Path

from nnmstop.explorer.browser import find_chromium, open_page
from timing import check_repeat, emit_report

STEPS = ("scriptStart", "dataDecoded", "frequencyEnergyDrawn", "ready")
# CPU time of the renderer's main thread and of the whole renderer process until ready: what the first
# render costs, nearly independent of the other programs that share the machine (wall times are not)
CPU = ("ThreadTime", "ProcessTime")


def render_timings(page_path: Path, repeat: int) -> list[dict]:
    runs = []
    for _ in range(check_repeat(repeat)):
        with open_page(page_path, metrics=True) as (page, log, _):
            errors = [m for m in log["console"] if m[0] in ("error", "pageerror")]
            if errors:
                raise RuntimeError(f"the page logged errors: {errors}")
            run = page.evaluate("window.explorer.timings")
            run.update({name: 1e3 * log["metrics"][name] for name in CPU})
            runs.append(run)
    return runs


def size_parts(page_path: Path) -> list[tuple[str, int]]:
    """Bytes of the page by part: the data of each branch, the inlined scripts and the rest."""
    html = page_path.read_text(encoding="utf-8")
    block = re.search(r'(<script type="application/json" id="explorer-data">)(.*?)(</script>)', html, re.S).group(2)
    data = json.loads(block)
    parts = [
        (f"data: {b['path']} ({b['points']} points)", len(json.dumps(b, separators=(",", ":"))))
        for b in data["branches"]
    ]
    scripts = sum(len(s) for s in re.findall(r"<script>(.*?)</script>", html, re.S))
    parts.append(("plotly.js and the page's scripts, inlined", scripts))
    parts.append(("the rest (HTML, style, data framing)", len(html.encode()) - sum(n for _, n in parts)))
    return parts


def machine() -> str:
    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor())  # fmt: skip
    version = subprocess.run([find_chromium(), "--version"], capture_output=True, text=True).stdout.strip()
    return f"{os.cpu_count()} cores, {cpu}; {version}"


def report(page_path: Path, runs: list[dict]) -> str:
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    size = page_path.stat().st_size
    lines = [
        f"Explorer page `{page_path}` at commit `{commit}`: {size / 1e6:.2f} MB ({size} bytes).",
        f"Machine: {machine()}; load average {os.getloadavg()[0]:.2f} (1 min) when the report was written.",
        "",
        f"First render in headless Chromium at 1280 x 800, {len(runs)} runs, fresh profile each "
        "(milliseconds since the navigation started, the page's own clock):",
        "",
        "| step | median (ms) | best (ms) |",
        "|---|---:|---:|",
    ]
    for step in STEPS:
        values = [run[step] for run in runs]
        lines.append(f"| {step} (wall) | {statistics.median(values):.0f} | {min(values):.0f} |")
    for name, text in zip(CPU, ("main thread CPU until ready", "renderer process CPU until ready")):
        values = [run[name] for run in runs]
        lines.append(f"| {text} | {statistics.median(values):.0f} | {min(values):.0f} |")
    lines += ["", "Size by part:", "", "| part | bytes | share |", "|---|---:|---:|"]
    lines += [f"| {name} | {n} | {100 * n / size:.1f} % |" for name, n in size_parts(page_path)]
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--page", type=Path, default=Path("dist/explorer.html"))
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--output", type=Path)
    args = parser.parse_args(argv)
    if not args.page.is_file():
        parser.error(f"{args.page} does not exist; build it with `snakemake --cores 2 explorer`")
    return emit_report(report(args.page, render_timings(args.page, args.repeat)), args.output)


if __name__ == "__main__":
    sys.exit(main())
