"""Structures: the paper's 2-DOF oscillator and the structure passed to the engines."""
