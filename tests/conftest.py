"""Shared pytest fixtures."""

from pathlib import Path

import pytest

from nnmstop.model import ModelParameters

REPO_ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def repo_root() -> Path:
    """Root of the repository (where the Snakefile lives)."""
    return REPO_ROOT


@pytest.fixture(scope="session")
def paper_params() -> ModelParameters:
    """The paper's values: alpha = 30, beta = 1, delta = 1, eta = 0.1."""
    return ModelParameters(alpha=30.0, beta=1.0, delta=1.0, eta=0.1)
