"""nnmstop: nonlinear normal modes of a 2-DOF oscillator with a bilateral elastic stop.

Data flow: :mod:`nnmstop.models.two_dof` -> :mod:`nnmstop.exact` (closed-form orbits of the
non-smooth system) -> :mod:`nnmstop.hbm.system` / :mod:`nnmstop.continuation.anm` (regularized NNMs by
harmonic balance and asymptotic numerical continuation) -> :mod:`nnmstop.netcdf`
-> :mod:`nnmstop.compare.matching` -> :mod:`nnmstop.figures`.
"""

__version__ = "0.1.0"
