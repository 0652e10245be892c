"""Exact against regularized: matching at energies, per-regime errors and stability verdicts."""
