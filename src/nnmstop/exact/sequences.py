"""Impact sequences: which linear phases make up the quarter period of an exact orbit.

An orbit of the symmetry class of Section 3.1 is decided by its quarter period, from the
origin crossing (always free flight) to the turning point where both velocities vanish.
Its *phase sequence* lists the linear phases met on the way, e.g. ``"FR"`` (one impact
per stop, Section 3.1) or ``"FLFR"``; see :data:`nnmstop.exact.phases.PHASE_NAMES`.
This module validates sequences, counts their impacts and edits them at a grazing
transition (a phase split in two, appended, or removed). Method notes:
``docs/methods/exact.md``.
"""

from __future__ import annotations

from nnmstop.exact.phases import PHASE_NAMES, STOP_SIDE

__all__ = ["check_sequence", "sequence_impacts", "switch_levels", "contact_phase", "split_sequence", "merged_sequence"]


def check_sequence(sequence: str) -> str:
    """Validate a quarter-period phase sequence and return it.

    A sequence starts with ``F`` (the quarter period starts at the origin) and
    alternates free flight with contact phases (``R`` or ``L``): x can only reach a
    stop from free flight.

    Raises
    ------
    ValueError
        If the sequence is empty, holds other letters, does not start with ``F`` or has
        two consecutive contact or free-flight phases.
    """
    if not isinstance(sequence, str) or not sequence:
        raise ValueError(f"a phase sequence is a non-empty string of F, R, L; got {sequence!r}")
    bad = sorted(set(sequence) - set(PHASE_NAMES))
    if bad:
        raise ValueError(f"phase sequence {sequence!r} holds unknown phases {bad}; use F, R, L")
    if sequence[0] != "F":
        raise ValueError(f"phase sequence {sequence!r} must start with free flight F (x = 0 at t = 0)")
    for a, b in zip(sequence, sequence[1:]):
        if (a == "F") == (b == "F"):
            raise ValueError(
                f"phase sequence {sequence!r}: {a}{b} is impossible, free flight and contact phases alternate"
            )
    return sequence


def sequence_impacts(sequence: str) -> int:
    """Excursions beyond ``|x| > 1`` per period of the orbit with this quarter-period sequence.

    ``2 (c0 + 2 m)``: ``c0 = 1`` if the last phase is a contact (one excursion per half
    period around the turning point), ``m`` the number of the other contact phases
    (each seen twice per half period, at ``t`` and ``-t``). The same count as
    :func:`nnmstop.hbm.system.impacts_per_period` gives from samples of a regularized orbit.

    Examples
    --------
    >>> sequence_impacts("FR"), sequence_impacts("FLFR"), sequence_impacts("FLF")
    (2, 6, 4)
    """
    check_sequence(sequence)
    contacts = sum(p != "F" for p in sequence)
    last = sequence[-1] != "F"
    return 2 * (int(last) + 2 * (contacts - int(last)))


def switch_levels(sequence: str) -> tuple:
    """Position of x (+1 or -1) at the end of every phase but the last: the stop shared with the next phase."""
    check_sequence(sequence)
    return tuple(STOP_SIDE[b] if b != "F" else STOP_SIDE[a] for a, b in zip(sequence, sequence[1:]))


def contact_phase(level: float) -> str:
    """The contact phase with the stop at ``x = level`` (``"R"`` for +1, ``"L"`` for -1)."""
    return "R" if level > 0 else "L"


def split_sequence(sequence: str, phase: int, level: float, at_end: bool) -> str:
    """The longer sequence after a grazing in ``phase`` of ``sequence`` at the stop ``x = level``.

    An interior grazing splits the phase (``F -> F R F`` or ``F L F``, ``R -> R F R``); a grazing
    at the turning point (``at_end``) appends the new phase.
    """
    kind = sequence[phase]
    new_kind = contact_phase(level) if kind == "F" else "F"
    if at_end:
        return sequence + new_kind
    return sequence[: phase + 1] + new_kind + sequence[phase:]


def merged_sequence(sequence: str, phase: int) -> str:
    """The shorter sequence when phase ``phase`` of ``sequence`` shrinks to zero duration.

    Raises
    ------
    ValueError
        If the phase cannot disappear generically (the first phase, or a free flight
        between the two different stops).
    """
    n = len(sequence)
    if phase == 0:
        raise ValueError("the first free flight cannot vanish (x = 0 at its start)")
    if phase == n - 1:
        return sequence[:-1]
    before, after = sequence[phase - 1], sequence[phase + 1]
    if before != after:
        raise ValueError(f"phase {phase + 1} of {sequence!r} lies between {before} and {after}; it cannot vanish")
    return sequence[:phase] + sequence[phase + 2 :]
