"""nnmstop: nonlinear normal modes of a 2-DOF oscillator with a bilateral elastic stop.

Data flow: :mod:`nnmstop.model` -> :mod:`nnmstop.exact` (closed-form orbits of the
non-smooth system) -> :mod:`nnmstop.hbm` / :mod:`nnmstop.anm` (regularized NNMs by
harmonic balance and asymptotic numerical continuation) -> :mod:`nnmstop.datasets`
-> :mod:`nnmstop.compare` -> :mod:`nnmstop.figures`.
"""

__version__ = "0.1.0"
