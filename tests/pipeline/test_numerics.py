"""The pinned-numerics policy (nnmstop.pipeline.numerics): kernels a CPU can run, names numpy accepts."""

from __future__ import annotations

import os
import subprocess
import sys

from nnmstop.pipeline.numerics import (
    OPENBLAS_KERNELS,
    cpu_flags,
    numerics_env,
    numpy_disabled_features,
    openblas_coretype,
)

# Instruction sets each OpenBLAS kernel family executes (OpenBLAS kernel/x86_64 sources).
NEEDS = {"Haswell": {"avx2", "fma", "avx", "sse3"}, "Sandybridge": {"avx", "sse3"}, "Prescott": {"sse3"}}


def test_never_a_kernel_the_cpu_cannot_run():
    cpus = [
        set(),
        {"sse3"},
        {"sse3", "avx"},
        {"sse3", "avx", "avx2"},
        {"sse3", "avx", "fma"},
        {"sse3", "avx", "avx2", "fma"},
        {"sse3", "avx", "avx2", "fma", "avx512f"},
    ]
    for flags in cpus:
        kernel = openblas_coretype(flags, machine="x86_64")
        assert kernel is None or NEEDS[kernel] <= flags, (flags, kernel)
    assert openblas_coretype({"sse3", "avx", "avx2", "fma", "avx512f"}, machine="x86_64") == "Haswell"
    assert openblas_coretype({"sse3", "avx", "avx2"}, machine="x86_64") == "Sandybridge"  # AVX2 without FMA
    assert openblas_coretype({"avx2", "fma"}, machine="aarch64") is None
    assert {name for name, _ in OPENBLAS_KERNELS} == set(NEEDS)


def test_cpu_flags_read_sse3_from_pni(tmp_path):
    cpuinfo = tmp_path / "cpuinfo"
    cpuinfo.write_text("processor\t: 0\nflags\t\t: fpu pni avx\n\nprocessor\t: 1\nflags\t\t: fpu pni avx\n")
    assert cpu_flags(cpuinfo) == {"fpu", "pni", "sse3", "avx"}
    assert cpu_flags(tmp_path / "missing") == set()


def test_env_overrides_threads_and_the_shell_kernel(tmp_path):
    cpuinfo = tmp_path / "cpuinfo"
    cpuinfo.write_text("flags\t: pni avx avx2 fma\n")
    env = numerics_env(cpuinfo=cpuinfo)
    assert {env[v] for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")} == {"1"}
    if os.uname().machine == "x86_64":
        assert env["OPENBLAS_CORETYPE"] == "Haswell"
    assert "OPENBLAS_CORETYPE" not in numerics_env(pin_kernels=False, cpuinfo=cpuinfo)


def test_numpy_accepts_the_disabled_features():
    """numpy 2.4 refuses unknown names at import: a fresh interpreter must import numpy with them."""
    disabled = numpy_disabled_features()
    if disabled is None:
        return
    assert "X86_V3" not in disabled.split()
    env = dict(os.environ, NPY_DISABLE_CPU_FEATURES=disabled)
    code = "import numpy._core._multiarray_umath as m; print(' '.join(k for k, v in m.__cpu_features__.items() if v))"
    enabled = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    ).stdout.split()
    assert not set(disabled.split()) & set(enabled)
