"""Exact periodic orbits of the non-smooth (piecewise-linear) system, in closed form.

phases (linear phases, time histories) -> sequences (impact sequences) -> problem (the
quarter-period equations of a sequence) -> grazing (validity, grazing transitions) ->
family (one continuation) -> dataset; stability (Floquet multipliers). Method notes:
``docs/methods/exact.md`` and ``docs/methods/exact_stability.md``.
"""
