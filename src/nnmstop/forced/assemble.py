"""A forced response of an excitation as its dataset: the one path of the pipeline's tasks and of the API.

:func:`exact_response_dataset` (the exact responses of the piecewise-linear law, :mod:`nnmstop.exact.forced`)
and :func:`regularized_response_dataset` (harmonic balance and the ANM, with the multipliers at the precision
their verdicts need) return the datasets of :mod:`nnmstop.forced.dataset`, unlabelled: the tasks write them
(:func:`nnmstop.netcdf.write_dataset`), :func:`nnmstop.api.forced_response` describes them from the catalogue.
"""

from __future__ import annotations

import dataclasses

import xarray as xr

from nnmstop.forced.dataset import exact_dataset, regularized_dataset
from nnmstop.forced.regularized import ForcedStabilitySettings, regularized_stability
from nnmstop.forced.responses import ExactSettings, RegularizedSettings, exact_response, regularized_response
from nnmstop.models.excitation import Excitation, modal_damping_ratios

__all__ = ["exact_response_dataset", "regularized_response_dataset", "point_accuracy"]


def exact_response_dataset(
    excitation: Excitation, frequency_range, settings: ExactSettings | None = None, resolution_factor: float = 2.0
) -> xr.Dataset:
    """The exact response over ``frequency_range`` (Hz) as a dataset (:func:`~nnmstop.forced.dataset.exact_dataset`);
    a verdict is resolved where its margin exceeds ``resolution_factor`` times the multipliers' error estimate."""
    pieces = exact_response(excitation, frequency_range, settings or ExactSettings())
    if not pieces:
        raise ValueError(
            f"the exact response has no piece over {frequency_range[0]:g}..{frequency_range[1]:g} Hz: the linear "
            "response is beyond the gap everywhere, with no grazing to start a contact family from (a smaller force "
            "or another frequency range)"
        )
    return exact_dataset(excitation, pieces, frequency_range, resolution_factor)


def regularized_response_dataset(
    excitation: Excitation,
    frequency_range,
    settings: RegularizedSettings | None = None,
    stability: ForcedStabilitySettings | None = None,
    label: str = "forced response",
) -> xr.Dataset:
    """The harmonic-balance response over ``frequency_range`` (Hz) with its multipliers and located changes."""
    settings, stability = settings or RegularizedSettings(), stability or ForcedStabilitySettings()
    system, branch = regularized_response(excitation, frequency_range, settings, label=label)
    verdicts, changes = regularized_stability(system, branch, settings.continuation, stability)
    ds = regularized_dataset(system, branch, verdicts.multipliers, False, changes, frequency_range)
    ds.update(verdicts.data_vars())
    ds.attrs.update({f"stability_{key}": value for key, value in dataclasses.asdict(stability).items()})
    ds.attrs["newton_threshold"] = settings.continuation.newton_threshold
    ds.attrs["point_accuracy"] = point_accuracy(excitation, settings.continuation.newton_threshold)
    return ds


def point_accuracy(excitation: Excitation, newton_threshold: float) -> float:
    """Relative accuracy of a stored point of a regularized response (the verifier's base tolerance): its relative
    residual stays below the Newton threshold, and the damped response amplifies a residual by up to the resonant
    amplification ``1 / (2 zeta)`` of its least damped linear mode (a mode within the lowest four)."""
    ratios = modal_damping_ratios(excitation, min(excitation.structure.n_dofs, 4))
    return float(newton_threshold / (2.0 * ratios.min()))
