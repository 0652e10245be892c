"""Why a study value was not computed: the :class:`Status` flags and their words.

Every ``status`` variable of the study's datasets holds a :class:`Status` (CF ``flag_values``
and ``flag_meanings``); :func:`status_words` turns such a variable, read back from a file, into
the reason a reader sees in the figures and tables. Method notes: ``docs/methods/study.md``.
"""

from __future__ import annotations

import enum

import numpy as np

__all__ = ["Status", "STATUS_MEANINGS", "status_words"]


class Status(enum.IntEnum):
    """Why a study value was not computed (the flag values of every ``status`` variable of the study).

    Each is an outcome the method expects, stored with its reason (the ``failure`` text);
    anything else fails the job.
    """

    #: computed (a case: converged and compared at every energy)
    COMPUTED = 0
    #: the truncation guard refused an orbit: H does not resolve the stop
    UNRESOLVED = 1
    #: the continuation ended before its stage did: max_steps exhausted, or a step it could not take
    CONTINUATION_ENDED = 2
    #: the energy lies outside the common range of the regularized two-impact run and the exact family
    OUTSIDE_COMMON_RANGE = 3
    #: the comparison does not apply (an orbit's x is not positive at its turning point in contact)
    NOT_APPLICABLE = 4
    #: the exact solver has no two-impact orbit at this energy
    NO_EXACT_ORBIT = 5


#: ``flag_meanings`` of the status variables, in the order of :class:`Status`.
STATUS_MEANINGS = " ".join(s.name.lower() for s in Status)

#: What each flag meaning says, in words for a reader.
_WORDS = {
    "unresolved": "not resolved by its harmonics (truncation guard)",
    "continuation_ended": "continuation ended before its stage did",
    "outside_common_range": "energies outside the common two-impact range",
    "not_applicable": "comparison does not apply (x <= 0 at the turning point in contact)",
    "no_exact_orbit": "no exact two-impact orbit",
}


def status_words(status) -> np.ndarray:
    """The reason of each element of a status flag variable (an ``xarray.DataArray`` with
    ``flag_values`` and ``flag_meanings``), in words; '' where the value was computed."""
    meanings = str(status.attrs["flag_meanings"]).split()
    values = np.asarray(status.attrs["flag_values"]).tolist()
    words = {v: _WORDS.get(m, m.replace("_", " ")) for v, m in zip(values, meanings)}
    words[0] = ""
    return np.vectorize(lambda s: words[int(s)], otypes=[object])(np.asarray(status.values))
