"""The workflow's command line for the end-to-end tests: one place builds it and runs it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def snakemake_command(workdir: Path, config: Path, *args: str) -> list[str]:
    """``python -m snakemake`` on the repository's Snakefile, in ``workdir``, with ``config``."""
    return [sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "--directory", str(workdir),
            "--configfile", str(config), *args]  # fmt: skip


def run_snakemake(workdir: Path, config: Path, *args: str, check: bool = True, timeout: float = 600):
    """Run the workflow; with ``check`` a failure raises AssertionError with the end of its output."""
    cmd = snakemake_command(workdir, config, *args)
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    if check and result.returncode != 0:
        raise AssertionError(f"{' '.join(cmd)} failed:\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}")
    return result
