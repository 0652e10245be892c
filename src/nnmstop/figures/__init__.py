"""Figures of the paper (Figs 2-11) and of the studies, built from datasets only.

A figure module reads datasets and reconstructs time histories from their Fourier
coefficients; it never continues a branch.
"""
