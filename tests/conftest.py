"""Shared pytest fixtures."""

import os

# One BLAS thread, set before numpy loads: the matrices here are small, and threads
# oversubscribed on a busy 2-core machine slow dense factorizations tenfold.
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import fcntl  # noqa: E402
import shutil  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

from nnmstop.models.two_dof import ModelParameters  # noqa: E402
from snakemake_cli import run_snakemake  # noqa: E402

REPO_ROOT = Path(__file__).resolve().parents[1]
SMALL_CONFIG = REPO_ROOT / "tests" / "data" / "small_config.yaml"


def pytest_addoption(parser):
    parser.addoption(
        "--cpu-variants",
        default="none",
        help="rerun the tests marked 'numerics' under other BLAS kernels and SIMD levels "
        "(tests/test_cpu_variants.py): 'none' (default: the suite's budget), 'all', or a comma-separated list "
        "of variant names (sandybridge, prescott-nosimd)",
    )


#: Test modules whose tests take the most CPU time (``python -m pytest --durations=40`` on a quiet machine), longest
#: first: the two xdist workers (``--dist loadscope``: each module, or test class, stays on one worker, so its
#: module fixtures are made once) start with them, so that neither is left alone with a long module at the end.
LONGEST_MODULES = (
    "tests/test_cpu_variants.py",
    "tests/test_workflow.py",
    "tests/study/test_study.py",
    "tests/study/test_stiff.py",
    "tests/tube/test_tube_workflow.py",
    "tests/study/test_study_workflow.py",
    "tests/pipeline/test_verify.py",
    "tests/pipeline/test_faults.py",
    "tests/pipeline/test_worker.py",
)


def pytest_collection_modifyitems(config, items):
    """The longest modules first (see LONGEST_MODULES); the order within a module is kept."""
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


@pytest.fixture(scope="session")
def small_build(tmp_path_factory) -> Path:
    """Working folder of the small configuration's default target (Figs 2-11, every dataset behind
    them, the manifest), built once per test session: the xdist workers of a session share it (the
    first one builds it while holding a lock). Tests copy what they alter and add nothing but their
    own outputs (a report, a bundle) to it."""
    root = tmp_path_factory.getbasetemp()
    if "PYTEST_XDIST_WORKER" in os.environ:
        root = root.parent  # the folder of the whole session, shared by its workers
    workdir = root / "small_build"
    with open(root / "small_build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (workdir / "built").exists():
            shutil.rmtree(workdir, ignore_errors=True)
            workdir.mkdir()
            run_snakemake(workdir, SMALL_CONFIG, "--cores", "2")
            (workdir / "built").touch()
    return workdir
