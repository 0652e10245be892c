"""The parameters of an atlas: the forcing frequency and amplitude, and one structural parameter.

Every point of an atlas is a periodic response at the parameters ``(Omega, F, p)``: ``Omega`` the angular
frequency of the force (rad per unit time), ``F`` its amplitude and ``p`` a structural parameter
(:data:`STRUCTURAL`): the struck stop's ``gap``, its ``stiffness`` (the regularization ``eta`` kept in
proportion, so that the regularized law keeps its shape) or the ``damping_ratio`` (the damping ratios that
define the Rayleigh damping, scaled together: ``C`` is linear in them, so ``p`` is the first ratio and the
others keep their proportions). :func:`with_parameters` gives the excitation at any such point.
"""

from __future__ import annotations

import dataclasses

from nnmstop.models.excitation import Damping, Excitation

__all__ = ["STRUCTURAL", "PLANES", "parameter_value", "with_parameters", "check_structural"]

#: Structural parameters an atlas can vary.
STRUCTURAL = ("gap", "stiffness", "damping_ratio")
#: The parameter planes of an atlas: the frequency against the force or against a structural parameter.
PLANES = ("force",) + STRUCTURAL


def check_structural(name, key: str = "parameter") -> str:
    """``name`` if it is one of :data:`STRUCTURAL` (or None), else ValueError naming what is allowed."""
    if name is not None and name not in STRUCTURAL:
        raise ValueError(f"{key} must be one of {list(STRUCTURAL)} (or None), got {name!r}")
    return name


def parameter_value(excitation: Excitation, name: str, stop: int = 0) -> float:
    """The value of the structural parameter ``name`` in ``excitation`` (the stop of index ``stop``)."""
    check_structural(name)
    if name == "damping_ratio":
        ratios = excitation.damping.ratios
        if ratios is None:
            raise ValueError(
                "parameter 'damping_ratio' needs a damping given by modal ratios (Damping.from_modal_ratios); this "
                "one is given by its Rayleigh coefficients"
            )
        return float(ratios[0])
    return float(getattr(excitation.structure.stops[stop], name))


def with_parameters(excitation: Excitation, force: float, name: str | None = None, value=None, stop: int = 0):
    """``excitation`` with force amplitude ``force`` and, when ``name`` is given, the structural parameter
    ``name`` set to ``value`` (ValueError where it is not > 0)."""
    out = excitation.with_amplitude(float(force))
    if name is None:
        return out
    value = float(value)
    if not value > 0:
        raise ValueError(f"the structural parameter {name!r} must be > 0, got {value!r}")
    if name == "damping_ratio":
        scale = value / parameter_value(excitation, name)
        damping = excitation.damping
        scaled = Damping(
            damping.mass_coefficient * scale,
            damping.stiffness_coefficient * scale,
            ratios=tuple(r * scale for r in damping.ratios),
        )
        return Excitation(out.structure, scaled, out.force)
    check_structural(name)
    structure = excitation.structure
    stops = list(structure.stops)
    old = stops[stop]
    if name == "gap":
        stops[stop] = dataclasses.replace(old, gap=value)
    else:
        stops[stop] = dataclasses.replace(old, stiffness=value, eta=old.eta * value / old.stiffness)
    return Excitation(dataclasses.replace(structure, stops=tuple(stops)), out.damping, out.force)
