"""Pinned numerics for the workflow's jobs: one BLAS thread, a fixed kernel choice.

OpenBLAS picks its kernels from the CPU at run time, and numpy picks its SIMD loops
the same way. Different kernels round differently, and the continuation amplifies
round-off into a different step sequence (the curve is the same, the stored points are
not). Forcing one kernel family on every machine that can run it makes such machines
produce byte-identical datasets. The policy is :func:`numerics_env`; the Snakefile puts
its result in ``os.environ`` before any job starts, and the jobs (subprocesses) inherit it.
See docs/reproducibility.md for the choice and what it was measured to give.
"""

from __future__ import annotations

import platform
import warnings
from pathlib import Path

__all__ = ["cpu_flags", "openblas_coretype", "numpy_disabled_features", "numerics_env"]

# Kernel families, most capable first, with the CPU flags (as /proc/cpuinfo names them)
# each one executes. A kernel is only chosen when all its flags are present: a kernel
# the CPU cannot run dies with an illegal instruction.
OPENBLAS_KERNELS = (
    ("Haswell", {"avx2", "fma"}),  # every AVX2+FMA CPU: Intel since 2013, AMD Zen, AVX-512 CPUs
    ("Sandybridge", {"avx"}),  # AVX without AVX2
    ("Prescott", {"sse3"}),  # SSE3 ("pni" in /proc/cpuinfo): any other x86_64
)

# numpy dispatch level matching the Haswell kernel family (AVX2 + FMA3).
NUMPY_LEVEL = "X86_V3"

THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def cpu_flags(cpuinfo: str | Path = "/proc/cpuinfo") -> set[str]:
    """CPU feature flags of the first processor listed in ``cpuinfo`` (empty if unreadable).

    ``pni`` (Prescott New Instructions) is reported as ``sse3`` too.
    """
    try:
        text = Path(cpuinfo).read_text()
    except OSError:
        return set()
    for line in text.splitlines():
        key, _, value = line.partition(":")
        if key.strip() == "flags":
            flags = set(value.split())
            return flags | {"sse3"} if "pni" in flags else flags
    return set()


def openblas_coretype(flags: set[str], machine: str | None = None) -> str | None:
    """The OpenBLAS kernel family to force on a CPU with ``flags``, or None for the native choice.

    Parameters
    ----------
    flags : set of str
        CPU flags, as :func:`cpu_flags` returns them.
    machine : str, optional
        ``platform.machine()`` by default; kernels are only pinned on x86_64.
    """
    machine = platform.machine() if machine is None else machine
    if machine not in ("x86_64", "AMD64"):
        return None
    for name, needed in OPENBLAS_KERNELS:
        if needed <= flags:
            return name
    return None


def numpy_disabled_features() -> str | None:
    """numpy SIMD dispatch targets to disable so that numpy runs its X86_V3 loops at most.

    Every dispatch target this numpy build knows except X86_V3 (the AVX-512 ones) is
    disabled. numpy itself never runs a target the CPU lacks, so an AVX2 CPU and an
    AVX-512 CPU both run the X86_V3 loops. Only names from numpy's own dispatch list are
    returned (numpy 2.4 refuses unknown names); None when numpy does not expose that list
    (its choice is then left alone) or there is nothing to disable.
    """
    try:
        from numpy._core import _multiarray_umath as umath
    except ImportError:
        return None
    disabled = [t for t in getattr(umath, "__cpu_dispatch__", []) if t != NUMPY_LEVEL]
    return " ".join(disabled) if disabled else None


def numerics_env(pin_kernels: bool = True, cpuinfo: str | Path = "/proc/cpuinfo") -> dict[str, str]:
    """Environment variables that pin the numerics of every job.

    Always one thread for OpenMP, OpenBLAS and MKL (jobs run side by side; a threaded
    reduction also changes the order of sums). With ``pin_kernels``, also

    - ``OPENBLAS_CORETYPE``: Haswell on any CPU with AVX2 and FMA, else Sandybridge
      (AVX), else Prescott (SSE3); CPUs of one family give the same bits;
    - ``NPY_DISABLE_CPU_FEATURES``: numpy's AVX-512 loops off, so that it runs the same
      X86_V3 loops as on an AVX2 CPU.

    Both override what the user's shell sets.

    On a CPU outside these families (not x86_64) the kernel is left to OpenBLAS and a
    warning says that datasets are then reproducible on that machine only.

    Parameters
    ----------
    pin_kernels : bool
        False leaves the kernel choice to OpenBLAS and numpy (config ``numerics.pin_kernels``).
    cpuinfo : str or Path
        Where the CPU flags are read.

    Returns
    -------
    dict
        Variable name to value; the caller overrides ``os.environ`` with it.
    """
    env = {name: "1" for name in THREAD_VARIABLES}
    if not pin_kernels:
        return env
    kernel = openblas_coretype(cpu_flags(cpuinfo))
    if kernel is None:
        warnings.warn(
            f"no pinned OpenBLAS kernel for this CPU ({platform.machine()}, flags from {cpuinfo}): "
            "OpenBLAS chooses natively, datasets are byte-reproducible on this machine only",
            RuntimeWarning,
            stacklevel=2,
        )
    else:
        env["OPENBLAS_CORETYPE"] = kernel
    disabled = numpy_disabled_features()
    if disabled:
        env["NPY_DISABLE_CPU_FEATURES"] = disabled
    return env
