"""Exact periodic orbits of the non-smooth (piecewise-linear) system, in closed form."""
