"""Continuation of solution curves: the ANM (with Pade) and Newton pseudo-arclength."""
