"""Accuracy, cost and robustness study of the NNM computations (issue 5).

Two studies, each a set of independent Snakemake jobs gathered into one dataset and
one figure. Their outputs are *measurements* (run times depend on the machine and its
load): they live under ``results/study/`` and ``paper_figures/error_vs_runtime.*``,
``paper_figures/stiff_cases.*``, are exempt from byte-identical reruns, and nothing
behind the paper's Figs 2-11 reads them.

* :mod:`nnmstop.study.error_runtime`: error against run time of the regularized NNM1
  (HBM + ANM) on the two-impact range, over the number of harmonics ``H``, the
  regularization ``eta`` and the ANM order and tolerance; the error against the exact
  non-smooth orbits is split into a regularization part and a truncation part.
* :mod:`nnmstop.study.stiff_cases`: stiff and extreme parameters (``alpha`` up to
  ``1e4``, ``eta`` down to ``1e-3``, energies ``1e-6`` to ``1e6``, ``beta`` and
  ``delta`` from ``0.01`` to ``100``): does the exact solver stay exact, does the
  continuation converge (with how many harmonics and steps), how far from the exact
  orbit.

Shared pieces (running one guarded continuation, matching energies, missing values)
are in :mod:`nnmstop.study.runs`.
"""
