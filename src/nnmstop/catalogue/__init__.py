"""The variable catalogue: every dataset the pipeline writes and every variable in it, described once.

A :class:`DatasetKind` names one layout of dataset (a regularized branch, an exact family, a
comparison, a study table, ...), the files that have it and its variables; a :class:`Variable`
holds a variable's name, dimensions, long name, units and, for flags and codes, the meaning of
each value. Numerical code returns plain arrays; :func:`nnmstop.netcdf.write_dataset` calls
:func:`describe`, which attaches this metadata and refuses a variable the kind does not list, a
variable with other dimensions, a missing required one, and a missing value where none may be.
``docs/datasets.md`` is generated from here: ``python -m nnmstop.catalogue > docs/datasets.md``
(``--check docs/datasets.md`` says whether the page is up to date).

One module per domain holds its kinds (:mod:`.branch`, :mod:`.exact`, :mod:`.compare`,
:mod:`.study`, :mod:`.tube`, :mod:`.forced`, :mod:`.atlas`); :data:`KINDS` gathers them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

__all__ = ["Variable", "DatasetKind", "KINDS", "kind", "describe", "markdown"]


@dataclass(frozen=True)
class Variable:
    """One variable (or coordinate) of a dataset kind.

    Attributes
    ----------
    name : str
    dims : tuple of str
        Its dimensions, in order (``()`` for a scalar).
    long_name : str
        CF ``long_name``: what the number is, in words.
    units : str
        CF units (``"1"`` for nondimensional quantities, ``"Hz"`` for frequencies of the nondimensional
        time, ``"s"`` for run times).
    flags : tuple of str
        For flags and codes: the meaning of the values ``0, 1, ...`` in order (CF ``flag_values`` and
        ``flag_meanings``); empty otherwise.
    optional : bool
        Whether a dataset of the kind may lack it.
    missing : str
        Empty: every value must be finite. Otherwise the values may be missing (NaN, written as the
        ``_FillValue`` :data:`FILL_VALUE`) and this says where and which variable gives the reason.
    reason : str
        Names (space-separated) of variables of the same dataset, with a subset of this one's
        dimensions, that say element by element why a value is missing: a non-empty string or a
        non-zero status flag. Written as the CF attribute ``ancillary_variables``; a missing value
        that none of them explains is refused (a value the dataset claims and lost). Integer
        variables with a sentinel (``-1: unknown``) name their reason the same way.
    """

    name: str
    dims: tuple
    long_name: str
    units: str = "1"
    flags: tuple = ()
    optional: bool = False
    missing: str = ""
    reason: str = ""

    def __post_init__(self):
        if isinstance(self.dims, str):
            object.__setattr__(self, "dims", (self.dims,))
        if any(" " in meaning for meaning in self.flags):
            raise ValueError(f"{self.name}: flag meanings are single words, got {self.flags}")

    def attrs(self) -> dict:
        """The CF attributes of the variable."""
        out = {"long_name": self.long_name, "units": self.units}
        if self.flags:
            out["flag_values"] = np.arange(len(self.flags), dtype=np.int8)
            out["flag_meanings"] = " ".join(self.flags)
        if self.reason:
            out["ancillary_variables"] = self.reason
        return out


#: ``_FillValue`` of the variables whose catalogue entry allows missing values.
FILL_VALUE = -9999.0


@dataclass(frozen=True)
class DatasetKind:
    """A layout of dataset: its name, the files that have it, a description and its variables."""

    name: str
    title: str
    files: tuple
    description: str
    variables: tuple

    def __post_init__(self):
        names = [v.name for v in self.variables]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"dataset kind {self.name!r} lists {repeated} more than once")

    def __getitem__(self, name: str) -> Variable:
        for variable in self.variables:
            if variable.name == name:
                return variable
        raise KeyError(name)

    def __contains__(self, name: str) -> bool:
        return any(v.name == name for v in self.variables)

    def extended(self, name: str, title: str, files: tuple, description: str, *variables: Variable) -> DatasetKind:
        """Another kind with this one's variables plus ``variables`` (a variable of the same name replaces)."""
        added = {v.name for v in variables}
        kept = tuple(v for v in self.variables if v.name not in added)
        return DatasetKind(name, title, files, description, kept + tuple(variables))


def _collect() -> dict:
    from nnmstop.catalogue import atlas, branch, compare, exact, forced, study, tube

    kinds = {}
    for module in (exact, branch, compare, tube, study, forced, atlas):
        for entry in module.KINDS:
            if entry.name in kinds:
                raise ValueError(f"dataset kind {entry.name!r} is defined twice")
            kinds[entry.name] = entry
    return kinds


def kind(name: str) -> DatasetKind:
    """The dataset kind ``name``; ``ValueError`` naming the known kinds otherwise."""
    try:
        return KINDS[name]
    except KeyError:
        raise ValueError(f"unknown dataset kind {name!r}; the catalogue has {sorted(KINDS)}") from None


def describe(ds: xr.Dataset, kind_name: str) -> xr.Dataset:
    """A copy of ``ds`` with the catalogue's attributes on every variable, checked against kind ``kind_name``.

    Missing values (NaN) of variables whose entry allows them are written as :data:`FILL_VALUE`
    (attribute ``_FillValue``), so a reader gets NaN back and never a number that looks valid. The
    dataset kind is recorded in the global attribute ``dataset_kind``.

    Raises
    ------
    ValueError
        Naming the variable: not listed for the kind, other dimensions, a required variable missing,
        or non-finite values where the catalogue allows none.
    """
    spec = kind(kind_name)
    out = ds.copy()
    for name in out.variables:
        if name not in spec:
            raise ValueError(
                f"variable {name!r} is not in the catalogue's dataset kind {kind_name!r} "
                f"(src/nnmstop/catalogue/); add it there with its long name and units"
            )
        entry = spec[name]
        var = out[name]
        if tuple(var.dims) != entry.dims:
            raise ValueError(
                f"variable {name!r} of a {kind_name!r} dataset has dimensions {tuple(var.dims)}, the catalogue "
                f"says {entry.dims}"
            )
        described = ("long_name", "units", "flag_values", "flag_meanings", "ancillary_variables")
        kept = {k: v for k, v in var.attrs.items() if k not in described}
        var.attrs = {**entry.attrs(), **kept}
        _check_values(name, var, entry, kind_name)
        _check_reasons(out, name, entry, kind_name)
    missing = [v.name for v in spec.variables if not v.optional and v.name not in out.variables]
    if missing:
        raise ValueError(f"a {kind_name!r} dataset must hold {missing} (catalogue), it does not")
    out.attrs = {**out.attrs, "dataset_kind": kind_name}
    return out


def _check_values(name: str, var: xr.DataArray, entry: Variable, kind_name: str) -> None:
    if not np.issubdtype(var.dtype, np.number):
        return
    finite = np.isfinite(var.values)
    if finite.all():
        return
    if not entry.missing or not np.issubdtype(var.dtype, np.floating):
        raise ValueError(
            f"variable {name!r} of a {kind_name!r} dataset holds {np.count_nonzero(~finite)} NaN or infinite "
            "value(s) where the catalogue allows none; refusing to write the dataset"
        )
    if np.isinf(var.values).any():
        raise ValueError(f"variable {name!r} holds infinite values; refusing to write the dataset")
    var.attrs["_FillValue"] = FILL_VALUE


def _reason_given(reason: xr.DataArray) -> np.ndarray:
    """Where a reason variable says "not computed": a non-empty string, or a non-zero status flag."""
    values = np.asarray(reason.values)
    if values.dtype.kind in "OUS":
        return np.vectorize(lambda v: bool(str(v)), otypes=[bool])(values).reshape(values.shape)
    if values.dtype.kind in "iub":
        return values != 0
    raise ValueError(
        f"variable {reason.name!r} cannot give a reason for missing values: it must hold strings (empty: "
        f"computed) or integer status flags (0: computed), not {values.dtype}"
    )


def _check_reasons(ds: xr.Dataset, name: str, entry: Variable, kind_name: str) -> None:
    """Refuse a missing value (NaN) of ``name`` that none of the variables of ``entry.reason`` explains."""
    var = ds[name]
    if not entry.reason or not np.issubdtype(var.dtype, np.floating):
        return
    missing = np.isnan(var.values)
    if not missing.any():
        return
    explained = np.zeros(var.shape, dtype=bool)
    for reason_name in entry.reason.split():
        if reason_name not in ds.variables or not set(ds[reason_name].dims) <= set(var.dims):
            raise ValueError(
                f"variable {name!r} of a {kind_name!r} dataset names {reason_name!r} as the reason of its missing "
                "values; the dataset must hold it, with a subset of its dimensions"
            )
        given = xr.DataArray(_reason_given(ds[reason_name]), dims=ds[reason_name].dims)
        explained |= given.broadcast_like(var).transpose(*var.dims).values
    unexplained = missing & ~explained
    if unexplained.any():
        index = dict(zip(var.dims, np.argwhere(unexplained)[0].tolist()))
        raise ValueError(
            f"variable {name!r} of a {kind_name!r} dataset is missing at {index} where {entry.reason.split()} say "
            "it was computed; refusing to write a dataset that lost a value it claims"
        )


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def _kind_markdown(spec: DatasetKind) -> list:
    lines = [f"## `{spec.name}`: {spec.title}", ""]
    lines += ["Files: " + ", ".join(f"`{f}`" for f in spec.files) + ".", "", spec.description.strip(), ""]
    lines += ["| variable | dimensions | units | meaning |", "|---|---|---|---|"]
    for v in spec.variables:
        meaning = v.long_name
        if v.flags:
            meaning += " (values: " + ", ".join(f"{i} {m}" for i, m in enumerate(v.flags)) + ")"
        if v.missing:
            meaning += f"; may be missing: {v.missing}"
        if v.reason:
            meaning += " (reason: " + ", ".join(f"`{r}`" for r in v.reason.split()) + ")"
        if v.optional:
            meaning += " (optional)"
        dims = ", ".join(v.dims) if v.dims else "scalar"
        lines.append(f"| `{v.name}` | {dims} | {_cell(v.units)} | {_cell(meaning)} |")
    return lines + [""]


PREAMBLE = """\
# Datasets of the pipeline

<!-- Generated by `python -m nnmstop.catalogue` from src/nnmstop/catalogue/; do not edit by hand
(tests/test_catalogue.py fails when this page and the catalogue differ). -->

Every dataset is a NetCDF-4 file written by `nnmstop.netcdf.write_dataset`, which takes the metadata
of every variable from the variable catalogue (`src/nnmstop/catalogue/`) and refuses a variable the
catalogue does not list for the dataset's kind (global attribute `dataset_kind`). Every file carries
the CF-1.10 / ACDD-1.3 global attributes (`title`, `summary`, `id` = its place under `results/`,
`date_created` = the commit date, `source` and `history` = package version and commit, the
`metadata:` section of the configuration), the physics and numerical settings it was computed with,
`long_name`, `units` and `coverage_content_type` on every variable, and no NaN or infinite value
except where a variable below says what may be missing (written as `_FillValue`, with a variable
giving the reason). Units: `"1"` for nondimensional quantities, `Hz` for frequencies of the
nondimensional time (`1/T`), `s` for run times (study datasets only). Files are written under a
temporary name and renamed, so an interrupted run leaves no partial file.

Read a dataset with xarray, for example
`xr.open_dataset("results/hbm/nnm1.nc")[["energy", "frequency", "stable"]]`.
"""


def markdown() -> str:
    """The dataset reference page ``docs/datasets.md``."""
    lines = [PREAMBLE]
    for spec in KINDS.values():
        lines += _kind_markdown(spec)
    return "\n".join(lines).rstrip() + "\n"


KINDS: dict = _collect()

__all__ += ["FILL_VALUE"]
