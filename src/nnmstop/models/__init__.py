"""Structures whose nonlinear normal modes the harmonic-balance engine computes."""
