"""The stored accuracy of a dataset's orbits against their recomputed residual.

A dataset stores its orbits (Fourier coefficients, start velocities and phase durations, the state of a
contact) and how accurate they are (a residual per orbit, or the threshold of the method that solved them).
A damaged or altered file can hold finite numbers that are no orbit at all (one flipped bit of one
coefficient gives 1e307): :func:`orbit_checks` rebuilds the equations of each orbit from the dataset's
own attributes (the structure, the harmonics, the excitation) and recomputes its residual, and
:func:`check_orbits` refuses a dataset whose orbits do not satisfy them to the accuracy it states, naming
the file, the variable and the point. The reader of every task (:func:`nnmstop.netcdf.read_dataset`) and
the verifier (:mod:`nnmstop.pipeline.verify`) use them.

What is recomputed, by dataset kind (``dataset_kind``):

* regularized branches (``nnm_branch``, ``switched_branch``) and the regularized orbits of the comparison
  (``exact_vs_regularized``): the relative residual of the harmonic balance against the stored one
  (``algebraic_residual``, ``regularized_residual``);
* the exact two-impact orbits (``two_impact_family``, the comparison's exact orbits): the residual of their
  quarter-period equations against the stored one; every exact family: its energy from the start
  velocities (closed form) and ``frequency * period = 1``;
* the exact forced responses (``forced_exact``): each contact state (``contact_unknowns``) solves its
  equations, reproduces its point's frequency and amplitudes by the closed-form flow, and points to a point
  of a one-contact segment (``contact_point_index``); each non-impacting point's amplitudes are those of
  the linear response;
* the regularized forced responses (``forced_regularized``): the relative residual of the forced harmonic
  balance against the Newton threshold the dataset states.

Every orbit of a file is recomputed up to :data:`MAX_CHECKED` points, an even sample of a larger one.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

__all__ = [
    "ACCURACY_FACTOR",
    "MAX_CHECKED",
    "OrbitCheck",
    "structure_from_attributes",
    "orbit_checks",
    "check_orbits",
    "checked_kinds",
]

#: A recomputed residual may exceed the stored one by this factor (round-off of another CPU is far less).
ACCURACY_FACTOR = 10.0
#: Floor of a recomputed residual (round-off of the residual's own evaluation), for a stiffness of the order of
#: the mass (scaled by their ratio, :func:`_stiffness_scale`).
ROUND_OFF = 1e-12
#: Relative accuracy of a number computed in closed form from a stored orbit (energy, amplitude, frequency).
CLOSED_FORM = 1e-9
#: Most orbits recomputed per file: above, an even sample of this many (ends included).
MAX_CHECKED = 2000


@dataclass(frozen=True)
class OrbitCheck:
    """One recomputation over the orbits of a dataset.

    Attributes
    ----------
    variables : tuple of str
        The variables that hold the orbits (and the stored accuracy) it checks.
    measure : str
        What was recomputed, in words.
    points : ndarray of int
        The orbits checked, as indices along ``dim``.
    recomputed, allowed : ndarray
        Per checked orbit: the recomputed value (a residual, a relative difference) and its bound.
    dim : str
        The dimension the orbits are along (``point``, ``contact_point``).
    """

    variables: tuple
    measure: str
    points: np.ndarray
    recomputed: np.ndarray
    allowed: np.ndarray
    dim: str = "point"

    @property
    def failed(self) -> np.ndarray:
        """Positions (into ``points``) where the recomputed value exceeds its bound (or is not a number)."""
        return np.flatnonzero(~(np.asarray(self.recomputed) <= np.asarray(self.allowed)))

    def worst(self) -> int:
        """Position of the largest ratio of recomputed value to bound."""
        ratio = np.where(np.isfinite(self.recomputed), self.recomputed / np.maximum(self.allowed, 1e-300), np.inf)
        return int(np.argmax(ratio)) if len(ratio) else 0


def _sample(n: int) -> np.ndarray:
    """Indices of the orbits recomputed: all of them up to MAX_CHECKED, else an even sample with both ends."""
    if n <= MAX_CHECKED:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, MAX_CHECKED).round().astype(int))


# --------------------------------------------------------------------------- the model from the attributes


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _stops_of(ds: xr.Dataset) -> list:
    """The stops of a dataset: its ``stop_*`` variables (one per stop) or attributes (the first stop), each as the
    configuration's stop entry of its kind (``stop_kind``, ``stop_side``, ``stop_other_dof`` where a stop is not
    bilateral, :func:`nnmstop.hbm.dataset.stop_kind_variables`)."""
    keys = ("stop_dof", "stop_gap", "stop_stiffness", "stop_eta")
    source = ds.variables if all(k in ds.variables for k in keys) else ds.attrs
    if not all(k in source for k in keys):
        raise ValueError("it records no stops (stop_dof, stop_gap, stop_stiffness, stop_eta)")

    def column(key):
        value = source[key].values if hasattr(source[key], "values") else source[key]
        return np.array(value.split()) if isinstance(value, str) else np.atleast_1d(np.asarray(value))

    stops = [{"dof": int(d), "gap": float(g), "stiffness": float(k), "eta": float(e)} for d, g, k, e in
             zip(*(column(key) for key in keys))]  # fmt: skip
    kinds = "stop_kind" if "stop_kind" in source else "stop_kinds"  # a variable per stop, or a text attribute
    if kinds not in source:
        return stops
    sides = {1: "positive", -1: "negative"}
    for stop, kind, side, other in zip(stops, column(kinds), column("stop_side"), column("stop_other_dof")):
        kind, side = str(kind), int(side)
        if kind in ("relative", "circular"):
            stop["dofs"] = [stop.pop("dof"), int(other)]
        if kind != "bilateral":
            stop["kind"] = kind
        if side:
            stop["side"] = sides[side]
    return stops


def structure_from_attributes(ds: xr.Dataset):
    """The structure a dataset was computed with: :func:`full_structure_from_attributes`, reduced again where the
    dataset records a reduction (``reduction``, ``kept_modes``; the boundary DOFs are the first ``boundary_dofs``
    of its ``dof_label``: the contact DOFs and the extra ones the reduction kept physical)."""
    structure = full_structure_from_attributes(ds)
    if ds.attrs.get("reduction") != "craig_bampton":
        return structure
    from nnmstop.models.reduction import contact_dofs, craig_bampton

    boundary = np.atleast_1d(ds.attrs["boundary_full_dofs"]).astype(int)
    extra = sorted(set(boundary.tolist()) - set(contact_dofs(structure).tolist()))
    return craig_bampton(structure, int(ds.attrs["kept_modes"]), extra)


def full_structure_from_attributes(ds: xr.Dataset):
    """The :class:`~nnmstop.models.structure.Structure` a dataset was computed with, from its attributes.

    ``structure`` names the kind: ``two_dof`` (``alpha``, ``beta``, ``delta``, ``eta``), ``beam`` (the
    beam's physical data, :func:`nnmstop.models.beam.beam_attributes`) or ``matrices`` (each matrix file's
    path and SHA-256: the file must still be there, unchanged).

    Raises
    ------
    ValueError
        If the attributes do not describe a structure, or a matrix file is missing or changed.
    """
    attrs = ds.attrs
    kind = str(attrs.get("structure", "two_dof"))
    if kind == "two_dof":
        from nnmstop.models.structure import two_dof_structure
        from nnmstop.models.two_dof import ModelParameters

        missing = [k for k in ("alpha", "beta", "delta", "eta") if k not in attrs]
        if missing:
            raise ValueError(f"it does not record the oscillator's parameters {missing}")
        return two_dof_structure(ModelParameters(**{k: float(attrs[k]) for k in ("alpha", "beta", "delta", "eta")}))
    if kind == "beam":
        from nnmstop.models.beam import Beam, BeamStop, beam_structure

        columns = [np.atleast_1d(attrs[key]) for key in ("stop_nodes", "stop_gap_m", "stop_stiffness_N_per_m",
                                                          "stop_eta_N_per_m")]  # fmt: skip
        kinds = str(attrs.get("stop_kinds", " ".join(["bilateral"] * len(columns[0])))).split()
        stops = tuple(
            BeamStop(gap=float(g), stiffness=float(k), eta=float(e), node=int(n), kind=kind.split(":")[0],
                     side=kind.split(":")[1] if ":" in kind else None)
            for n, g, k, e, kind in zip(*columns, kinds)
        )  # fmt: skip
        beam = Beam(
            length=float(attrs["length_m"]),
            bending_stiffness=float(attrs["bending_stiffness_N_m2"]),
            mass_per_length=float(attrs["mass_per_length_kg_per_m"]),
            n_elements=int(attrs["elements"]),
            left=str(attrs["left_end"]),
            right=str(attrs["right_end"]),
            stops=stops,
            planes=int(attrs.get("planes", 1)),
        )
        return beam_structure(beam)
    if kind == "matrices":
        from nnmstop.models.matrices import matrix_structure

        files = {}
        for name in ("mass", "stiffness"):
            if f"{name}_file" not in attrs or f"{name}_sha256" not in attrs:
                raise ValueError(f"it does not record the {name} matrix's file and SHA-256")
            path = Path(str(attrs[f"{name}_file"]))
            if not path.is_file():
                raise ValueError(f"the {name} matrix file {path} it was computed with is missing")
            if _sha256(path) != str(attrs[f"{name}_sha256"]):
                raise ValueError(f"the {name} matrix file {path} changed since it was computed (SHA-256 differs)")
            files[name] = path
        labels = [str(v) for v in ds["dof_label"].values] if "dof_label" in ds.variables else None
        stops = _stops_of(ds)
        if ds.attrs.get("reduction") == "craig_bampton":  # stops on the reduced DOFs: back to the full model's
            full = np.atleast_1d(ds.attrs["boundary_full_dofs"]).astype(int)
            for stop in stops:
                for key in ("dof", "dofs"):
                    if key in stop:
                        stop[key] = int(full[stop[key]]) if key == "dof" else [int(full[d]) for d in stop[key]]
            labels = None
        return matrix_structure(files["mass"], files["stiffness"], stops, labels)
    raise ValueError(f"its structure kind {kind!r} is none of two_dof, beam, matrices")


def _hbm_system(ds: xr.Dataset):
    from nnmstop.hbm.system import HarmonicBalanceSystem

    missing = [k for k in ("harmonics", "time_samples", "basis") if k not in ds.attrs]
    if missing:
        raise ValueError(f"it does not record the harmonic balance's settings {missing}")
    from nnmstop.hbm.dataset import system_arguments

    structure = structure_from_attributes(ds)
    return HarmonicBalanceSystem(structure, int(ds.attrs["harmonics"]), **system_arguments(ds.attrs))


def _excitation(ds: xr.Dataset):
    from nnmstop.models.excitation import Damping, Excitation, HarmonicForce

    missing = [k for k in ("forcing_amplitude", "forcing_dofs", "rayleigh_mass_coefficient",
                           "rayleigh_stiffness_coefficient") if k not in ds.attrs]  # fmt: skip
    if missing:
        raise ValueError(f"it does not record the excitation {missing}")
    return Excitation(
        structure_from_attributes(ds),
        Damping(float(ds.attrs["rayleigh_mass_coefficient"]), float(ds.attrs["rayleigh_stiffness_coefficient"])),
        HarmonicForce(
            float(ds.attrs["forcing_amplitude"]), tuple(int(d) for d in np.atleast_1d(ds.attrs["forcing_dofs"]))
        ),
    )


# --------------------------------------------------------------------------- recomputations by kind


def _stiffness_scale(structure) -> float:
    """``max |K_ij| / max |M_ij|``, at least 1: the residual's round-off floor grows with it. Evaluating ``K q``
    costs ``eps |K| |q|``, and a structure rebuilt on another CPU differs at round-off relative to its largest
    entries (a reduction's modal stiffness reaches the square of its highest kept frequency, 1e3 to 1e4)."""
    largest = [float(abs(a).max()) for a in (structure.stiffness, structure.mass)]
    return max(1.0, largest[0] / largest[1])


def _regularized(ds: xr.Dataset, stored: str) -> list[OrbitCheck]:
    """Relative residual of the harmonic balance of each stored orbit against the stored one."""
    from nnmstop.continuation.core import relative_residual
    from nnmstop.hbm.dataset import dataset_unknowns

    if ds.sizes.get("point", 0) == 0:
        return []
    system = _hbm_system(ds)
    points = _sample(ds.sizes["point"])
    U = dataset_unknowns(ds.isel(point=points), system)
    with np.errstate(all="ignore"):
        recomputed = np.array([relative_residual(system, u) for u in U])
    allowed = ACCURACY_FACTOR * np.abs(ds[stored].values[points]) + ROUND_OFF * _stiffness_scale(system.structure)
    orbit = tuple(v for v in ("q_cos", "q_sin", "f_cos", "f_sin", "z_cos", "z_sin", "omega_squared", "unfolding")
                  if v in ds.variables)  # fmt: skip
    return [OrbitCheck((*orbit, stored), f"relative residual of the harmonic balance (stored: {stored})", points,
                       recomputed, allowed)]  # fmt: skip


def _closed_form_exact(ds: xr.Dataset, prefix: str = "") -> list[OrbitCheck]:
    """Energy of each exact orbit from its start velocities (the kinetic energy at the origin), and its
    frequency times its period."""
    if ds.sizes.get("point", 0) == 0 or f"{prefix}xdot0" not in ds.variables:
        return []
    checks = []
    points = np.arange(ds.sizes["point"])
    xdot, udot = ds[f"{prefix}xdot0"].values, ds[f"{prefix}udot0"].values
    energy_name = f"{prefix}energy" if f"{prefix}energy" in ds.variables else "energy"
    if "delta" in ds.attrs and "mass_matrix" not in ds.attrs and energy_name in ds.variables:  # M = diag(1, delta)
        delta = float(ds.attrs["delta"])
        with np.errstate(all="ignore"):
            energy = 0.5 * (xdot**2 + delta * udot**2)
            stored = ds[energy_name].values
            difference = np.abs(energy - stored) / np.maximum(np.abs(stored), 1e-300)
        checks.append(OrbitCheck((f"{prefix}xdot0", f"{prefix}udot0", energy_name),
                                 "relative difference of the energy from the start velocities (closed form)",
                                 points, difference, np.full(len(points), CLOSED_FORM)))  # fmt: skip
    if "frequency" in ds.variables and "period" in ds.variables and not prefix:
        with np.errstate(all="ignore"):
            product = np.abs(ds["frequency"].values * ds["period"].values - 1.0)
        checks.append(OrbitCheck(("frequency", "period"), "|frequency x period - 1|", points, product,
                                 np.full(len(points), CLOSED_FORM)))  # fmt: skip
    return checks


def _two_impact(ds: xr.Dataset, variables: tuple, unknowns, stored: str) -> list[OrbitCheck]:
    """Residual of the quarter-period equations of each two-impact orbit (``unknowns(ds)``: the columns xdot0,
    udot0, free flight time, quarter period) against the stored one; ``variables`` name what holds them."""
    from nnmstop.exact.problem import SequenceProblem
    from nnmstop.models.two_dof import ModelParameters

    if ds.sizes.get("point", 0) == 0:
        return []
    params = ModelParameters(**{k: float(ds.attrs[k]) for k in ("alpha", "beta", "delta")})
    problem = SequenceProblem(params, "FR")
    points = _sample(ds.sizes["point"])
    xdot, udot, tau, quarter = (np.asarray(column, dtype=float)[points] for column in unknowns(ds))
    recomputed = []
    with np.errstate(all="ignore"):
        for y in np.column_stack([xdot, udot, tau, quarter - tau]):
            try:
                recomputed.append(float(np.linalg.norm(problem.residual(y))))
            except ValueError:  # not finite
                recomputed.append(np.inf)
    allowed = ACCURACY_FACTOR * np.abs(ds[stored].values[points]) + ROUND_OFF
    return [OrbitCheck((*variables, stored), f"residual of the quarter-period equations (stored: {stored})", points,
                       np.array(recomputed), allowed)]  # fmt: skip


def _two_impact_family(ds: xr.Dataset) -> list[OrbitCheck]:
    names = ("xdot0", "udot0", "free_flight_time", "period")
    columns = lambda d: [d[n].values for n in names[:3]] + [d["period"].values / 4.0]  # noqa: E731
    return _closed_form_exact(ds) + _two_impact(ds, names, columns, "residual")


def _comparison(ds: xr.Dataset) -> list[OrbitCheck]:
    if ds.sizes.get("point", 0) == 0:
        return []
    checks = _regularized(ds, "regularized_residual")
    names = ("exact_xdot0", "exact_udot0", "exact_tau1", "exact_T1")
    checks += _two_impact(ds, names, lambda d: [d[n].values for n in names], "exact_residual")
    checks += _closed_form_exact(ds, prefix="exact_")
    return checks


#: The full-period exact orbits' stored switches (nnmstop.forced.dataset): checked together as one orbit each.
SWITCH_VARIABLES = ("switch_state", "switch_point", "switch_phase", "switch_contact", "switch_entry")


def _forced_exact(ds: xr.Dataset) -> list[OrbitCheck]:
    """Each contact state solves its equations and reproduces its point; each other point is the linear
    response (closed form)."""
    from nnmstop.forced.dataset import stored_contact_orbit
    from nnmstop.models.excitation import linear_response

    n = ds.sizes.get("point", 0)
    if n == 0:
        return []
    excitation = _excitation(ds)
    frequency, amplitude = ds["frequency"].values, ds["amplitude"].values
    checks = []
    contact = np.zeros(n, dtype=bool)
    if "contact_point_index" in ds.variables:  # orbits in contact: half-wave unknowns or full-period switches
        index = np.asarray(ds["contact_point_index"].values)
        kinds = str(ds.attrs.get("segment_kinds", "")).split()
        segment = ds["segment"].values
        one_contact = np.array([kinds[int(s)] == "one_contact" if 0 <= int(s) < len(kinds) else False
                                for s in segment])  # fmt: skip
        valid = (index >= 0) & (index < n)
        # the index must name each point of the one-contact segments once, in order
        placed = np.where(valid, index, 0)
        wrong = ~valid | ~one_contact[placed]
        if valid.all():
            wrong |= np.r_[False, np.diff(index) <= 0]
            if np.count_nonzero(one_contact) != len(index):
                missing = np.setdiff1d(np.flatnonzero(one_contact), index)
                wrong[np.searchsorted(index, missing).clip(0, len(index) - 1)] = True
        checks.append(OrbitCheck(("contact_point_index", "segment"),
                                 "index of a point of a one-contact segment, every such point once, in order",
                                 np.arange(len(index)), wrong.astype(float), np.zeros(len(index)),
                                 dim="contact_point"))  # fmt: skip
        contact[placed[valid]] = True
        rows = _sample(len(index))
        residual, mismatch = [], []
        for j in rows:
            i = int(placed[j])
            with np.errstate(all="ignore"):
                try:
                    # the half-wave unknowns, or the full-period orbit rebuilt from its stored switches
                    problem, y = stored_contact_orbit(ds, excitation, int(j))
                    residual.append(float(np.linalg.norm(problem.residual(y))) / max(1.0, float(np.abs(y).max())))
                    reproduced = problem.amplitudes(y)
                    got = np.r_[y[-1] / (2 * np.pi), reproduced]
                    want = np.r_[frequency[i], amplitude[i]]
                    mismatch.append(float(np.max(np.abs(got - want) / np.maximum(np.abs(want), 1e-300))))
                except (ValueError, FloatingPointError, np.linalg.LinAlgError):
                    residual.append(np.inf)
                    mismatch.append(np.inf)
        orbit = ("contact_unknowns",) if "contact_unknowns" in ds.variables else SWITCH_VARIABLES
        checks.append(
            OrbitCheck(
                orbit,
                "relative residual of the contact equations",
                rows,
                np.array(residual),
                np.full(len(rows), CLOSED_FORM),
                dim="contact_point",
            )
        )
        checks.append(OrbitCheck((*orbit, "contact_point_index", "frequency", "amplitude"),
                                 "relative difference of the point's frequency and amplitudes from the contact "
                                 "state's closed-form flow", rows, np.array(mismatch), np.full(len(rows), CLOSED_FORM),
                                 dim="contact_point"))  # fmt: skip
    free = np.flatnonzero(~contact)
    if len(free):
        points = free[_sample(len(free))]
        with np.errstate(all="ignore"):
            linear = np.abs(linear_response(excitation, 2 * np.pi * frequency[points]))
            difference = np.max(np.abs(linear - amplitude[points]) / np.maximum(np.abs(amplitude[points]), 1e-300),
                                axis=1)  # fmt: skip
        checks.append(OrbitCheck(("frequency", "amplitude"),
                                 "relative difference of the amplitudes from the linear response (closed form)",
                                 points, difference, np.full(len(points), CLOSED_FORM)))  # fmt: skip
    return checks


def _forced_regularized(ds: xr.Dataset) -> list[OrbitCheck]:
    """Relative residual of the forced harmonic balance of each stored orbit against the Newton threshold."""
    from nnmstop import fourier
    from nnmstop.continuation.core import relative_residual
    from nnmstop.hbm.forced import ForcedHarmonicBalanceSystem

    n = ds.sizes.get("point", 0)
    if n == 0:
        return []
    if "newton_threshold" not in ds.attrs:
        raise ValueError("it does not record the Newton threshold its orbits were solved to")
    system = ForcedHarmonicBalanceSystem(_excitation(ds), int(ds.attrs["harmonics"]))
    points = _sample(n)
    parts = []
    for symbol in ("q", "f", "z"):
        full = fourier.from_cos_sin(ds[f"{symbol}_cos"].values[points], ds[f"{symbol}_sin"].values[points])
        parts += [full[:, j, : system.nc] for j in range(full.shape[1])]
    omega = 2 * np.pi * ds["frequency"].values[points]
    U = np.concatenate(parts + [omega[:, None] ** 2, omega[:, None]], axis=1)
    with np.errstate(all="ignore"):
        recomputed = np.array([relative_residual(system, u) for u in U])
    bound = ACCURACY_FACTOR * float(ds.attrs["newton_threshold"])
    variables = ("q_cos", "q_sin", "f_cos", "f_sin", "z_cos", "z_sin", "frequency")
    return [OrbitCheck(variables, "relative residual of the forced harmonic balance (bound: 10 x newton_threshold)",
                       points, recomputed, np.full(len(points), bound))]  # fmt: skip


#: The recomputation of each dataset kind that stores orbits.
CHECKS = {
    "nnm_branch": lambda ds: _regularized(ds, "algebraic_residual"),
    "switched_branch": lambda ds: _regularized(ds, "algebraic_residual"),
    "exact_vs_regularized": _comparison,
    "two_impact_family": _two_impact_family,
    "exact_nnm1": _closed_form_exact,
    "stiff_exact": _closed_form_exact,
    "forced_exact": _forced_exact,
    "forced_regularized": _forced_regularized,
}


def checked_kinds() -> tuple:
    """The dataset kinds whose orbits are recomputed."""
    return tuple(CHECKS)


def orbit_checks(ds: xr.Dataset) -> list[OrbitCheck]:
    """The recomputations of the stored orbits of ``ds`` (by its ``dataset_kind``; none for a kind without
    orbits).

    Raises
    ------
    ValueError
        If the dataset does not record what its orbits' equations need (the reason says what).
    """
    check = CHECKS.get(str(ds.attrs.get("dataset_kind", "")))
    return check(ds) if check is not None else []


def _where(ds: xr.Dataset, check: OrbitCheck, position: int) -> str:
    index = int(check.points[position])
    where = f"{check.dim} {index}"
    point = index
    if check.dim == "contact_point" and "contact_point_index" in ds.variables:
        point = int(ds["contact_point_index"].values[index])
        where += f" (point {point})"
    for name in ("energy", "frequency"):
        if name in ds.variables and ds[name].dims == ("point",) and 0 <= point < ds.sizes["point"]:
            where += f", {name} {float(ds[name].values[point]):.6g}"
    return where


def check_orbits(ds: xr.Dataset, source) -> None:
    """Refuse ``ds`` (read from ``source``) when a stored orbit does not satisfy its equations to its stated
    accuracy.

    Raises
    ------
    ValueError
        Naming the file, the variables, the point and the recomputed value against its bound.
    """
    try:
        checks = orbit_checks(ds)
    except (KeyError, ValueError, TypeError) as error:
        raise ValueError(f"{source}: the accuracy of its orbits cannot be recomputed: {error}") from None
    for check in checks:
        failed = check.failed
        if len(failed):
            worst = check.worst()
            raise ValueError(
                f"{source}: {', '.join(check.variables)} at {_where(ds, check, worst)}: {check.measure} is "
                f"{check.recomputed[worst]:.3g}, above its bound {check.allowed[worst]:.3g} ({len(failed)} of "
                f"{len(check.points)} orbits checked): the file is damaged or altered; rebuild it"
            )
