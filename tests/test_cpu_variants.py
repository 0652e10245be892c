"""The round-off-sensitive tests (marker ``numerics``) under other CPU kernels.

OpenBLAS picks its kernels from the CPU at run time and numpy dispatches its loops to
the widest SIMD level the CPU has, so one machine sees only its own round-off. A
continuation's step sequence follows that round-off while its curve does not: the
tests must hold whatever the kernels. Each variant reruns ``python -m pytest -m
numerics`` in a subprocess with the environment that forces older kernels, on one
BLAS thread. ``--cpu-variants`` chooses the variants (``none`` skips them all).
"""

from __future__ import annotations

import os
import platform
import subprocess
import sys

import pytest


def numpy_dispatched_features() -> list[str]:
    """SIMD levels above numpy's baseline that this CPU has (what ``NPY_DISABLE_CPU_FEATURES`` may name).

    numpy refuses to start if that variable names a baseline feature, so only the
    dispatched targets found on this CPU are listed.
    """
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    except ImportError:  # another numpy layout: leave numpy's dispatch alone
        return []
    return [name for name in __cpu_dispatch__ if __cpu_features__.get(name)]


def cpu_has(feature: str) -> bool:
    try:
        from numpy._core._multiarray_umath import __cpu_features__
    except ImportError:
        return False
    return bool(__cpu_features__.get(feature))


#: name: (environment, CPU feature the kernels need, what it stands for)
VARIANTS = {
    "sandybridge": ({"OPENBLAS_CORETYPE": "Sandybridge"}, "AVX", "OpenBLAS AVX kernels (no FMA, no AVX2)"),
    "prescott-nosimd": (
        {"OPENBLAS_CORETYPE": "Prescott", "NPY_DISABLE_CPU_FEATURES": " ".join(numpy_dispatched_features())},
        "SSE3",
        "OpenBLAS SSE3 kernels and numpy at its baseline SIMD level",
    ),
}


def selected_variants(option: str) -> list[str]:
    """Variant names chosen by ``--cpu-variants`` (``all``, ``none`` or a comma-separated list)."""
    option = option.strip()
    if option == "all":
        return list(VARIANTS)
    if option == "none":
        return []
    names = [name.strip() for name in option.split(",") if name.strip()]
    unknown = [name for name in names if name not in VARIANTS]
    if unknown or not names:
        raise pytest.UsageError(
            f"--cpu-variants={option!r}: unknown variant(s) {unknown}; allowed: all, none, or a comma-separated "
            f"list of {', '.join(VARIANTS)}"
        )
    return names


def run_variant(name, request, repo_root):
    """Rerun the tests marked ``numerics`` under CPU variant ``name``; skip where it cannot run here."""
    if name not in selected_variants(request.config.getoption("--cpu-variants")):
        pytest.skip(f"CPU variant {name!r} not selected by --cpu-variants")
    if platform.machine().lower() not in ("x86_64", "amd64"):
        pytest.skip(f"OpenBLAS x86-64 core types do not exist on {platform.machine()}")
    settings, needs, meaning = VARIANTS[name]
    if not cpu_has(needs):
        pytest.skip(f"this CPU lacks {needs}, which the {name} kernels need")
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    env.update({key: value for key, value in settings.items() if value})
    command = [
        sys.executable,
        "-m",
        "pytest",
        "-q",
        "-p",
        "no:cacheprovider",
        "-m",
        "numerics",
        "-n",
        "0",  # one process per variant: the variants run side by side on the suite's workers
        "--cpu-variants=none",
        str(repo_root / "tests"),
    ]
    run = subprocess.run(command, cwd=repo_root, env=env, capture_output=True, text=True)
    shown = " ".join(f"{key}={value!r}" for key, value in settings.items() if value)
    assert run.returncode == 0, (
        f"tests marked 'numerics' fail under CPU variant {name} ({meaning}; {shown}):\n{run.stdout}\n{run.stderr}"
    )


# One class per variant: xdist (--dist loadscope) keeps a module's functions on one worker but
# schedules each class on its own, so the two variants run side by side.


class TestSandybridge:
    def test_numerics_tests_pass_under_other_cpu_kernels(self, request, repo_root):
        run_variant("sandybridge", request, repo_root)


class TestPrescottNoSimd:
    def test_numerics_tests_pass_under_other_cpu_kernels(self, request, repo_root):
        run_variant("prescott-nosimd", request, repo_root)


def test_every_variant_has_its_class():
    assert {"sandybridge": TestSandybridge, "prescott-nosimd": TestPrescottNoSimd}.keys() == VARIANTS.keys()
