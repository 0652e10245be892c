"""The small build that the explorer's tests read: `snakemake explorer` on tests/data/small_config.yaml."""

from __future__ import annotations

from pathlib import Path

import pytest

from snakemake_cli import run_snakemake

REPO = Path(__file__).resolve().parents[2]
SMALL_CONFIG = REPO / "tests" / "data" / "small_config.yaml"


@pytest.fixture(scope="session")
def small_build(tmp_path_factory) -> Path:
    """A work folder holding the small configuration's datasets, manifest and dist/explorer.html."""
    workdir = tmp_path_factory.mktemp("explorer_build")
    run_snakemake(workdir, SMALL_CONFIG, "--cores", "2", "explorer")
    return workdir
