"""Shared pytest fixtures."""

import os

# One BLAS thread, set before numpy loads: the matrices here are small, and threads
# oversubscribed on a busy 2-core machine slow dense factorizations tenfold.
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

from nnmstop.models.two_dof import ModelParameters  # noqa: E402

REPO_ROOT = Path(__file__).resolve().parents[1]


def pytest_addoption(parser):
    parser.addoption(
        "--cpu-variants",
        default="all",
        help="rerun the tests marked 'numerics' under other BLAS kernels and SIMD levels "
        "(tests/test_cpu_variants.py): 'all' (default), 'none', or a comma-separated list of "
        "variant names (sandybridge, prescott-nosimd)",
    )


def pytest_configure(config):
    config.addinivalue_line(
        "markers",
        "numerics: fast tests whose results hinge on round-off (continuations, located points); "
        "rerun under other CPU kernels by tests/test_cpu_variants.py",
    )


@pytest.fixture(scope="session")
def repo_root() -> Path:
    """Root of the repository (where the Snakefile lives)."""
    return REPO_ROOT


@pytest.fixture(scope="session")
def paper_params() -> ModelParameters:
    """The paper's values: alpha = 30, beta = 1, delta = 1, eta = 0.1."""
    return ModelParameters(alpha=30.0, beta=1.0, delta=1.0, eta=0.1)
