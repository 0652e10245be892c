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


#: Test modules whose tests take the most CPU time (``python -m pytest --durations=40`` on a quiet machine), longest
#: first: the two xdist workers start with them, so that neither is left alone with a long module at the end.
LONGEST_MODULES = (
    "tests/test_cpu_variants.py",
    "tests/test_workflow.py",
    "tests/study/test_study.py",
    "tests/study/test_stiff.py",
    "tests/tube/test_tube_workflow.py",
    "tests/pipeline/test_verify.py",
    "tests/pipeline/test_faults.py",
    "tests/pipeline/test_worker.py",
)


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Keep each test module on one xdist worker (``--dist loadgroup``: a module's fixtures, such as a
    workflow build, are made once), unless a test names its own ``xdist_group``; longest modules first."""
    for item in items:
        if not any(item.iter_markers("xdist_group")):
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))
    rank = {module: k for k, module in enumerate(LONGEST_MODULES)}
    items.sort(key=lambda item: rank.get(item.nodeid.split("::")[0], len(rank)))


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
