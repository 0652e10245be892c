"""Regularized NNMs by harmonic balance: the balanced system, branches, stability, branch points."""
