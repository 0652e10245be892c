"""Plumbing of the workflow, apart from the science: nothing in the numerical packages imports it.

``run`` dispatches a rule's task (its command line, ``python -m nnmstop.pipeline.run``); ``worker`` runs
tasks in forks of a warm interpreter; ``numerics`` pins the BLAS kernels of every job; ``verify``
compares a build with ``reference/``; ``bundle`` writes the citable archive; ``compliance`` runs the
CF/ACDD checker.
"""
