"""NetCDF datasets of the pipeline: labelled variables, writing, reading, staleness.

The one owner of the pipeline's file format. Variables are built with :func:`cf_variable`
(and :func:`flag_variable` for 0/1 flags), so each carries ``long_name`` and ``units``.
:func:`write_dataset` refuses unlabelled variables and NaN or infinite values (a failed
computation never leaves a dataset), adds the CF-1.10 / ACDD-1.3 global attributes
(``date_created`` from ``SOURCE_DATE_EPOCH`` or the commit date, never the clock; who made and
publishes the data from the configuration's ``metadata`` section), gives every variable a
``coverage_content_type`` and writes through a temporary file renamed at the end, so an
interrupted run leaves no partial file under the final name.

:func:`read_dataset` is the reader of every task (figures, stage starts, comparisons, manifests,
documentation pages, explorer): it loads an input into memory, checks the variables a task needs,
refuses NaN or infinity where numbers must be, and recomputes the residual of the stored orbits
against the accuracy the file states (:mod:`nnmstop.stored_accuracy`), so that a damaged file whose
numbers are finite but no orbits is refused, naming file, variable and point.
:func:`check_up_to_date` refuses an input whose recorded settings (global attributes such as
``alpha`` or ``harmonics``) differ from the configuration: a stale file that Snakemake did not
rebuild, for instance one copied in or built with ``--rerun-triggers mtime``.
"""

from __future__ import annotations

import datetime as _dt
import os
import subprocess
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np
import xarray as xr

from nnmstop import __version__
from nnmstop.atomic import atomic_output
from nnmstop.catalogue import describe

__all__ = [
    "PAPER_AUTHORS",
    "PAPER_REFERENCE",
    "PAPER_TITLE",
    "METADATA_ATTRIBUTES",
    "provenance",
    "global_attributes",
    "dataset_id",
    "cf_variable",
    "flag_variable",
    "check_labelled",
    "write_dataset",
    "read_dataset",
    "open_checked",
    "check_finite_values",
    "may_be_missing",
    "non_finite_variables",
    "check_up_to_date",
]

PAPER_TITLE = "Nonlinear normal modes of a two degree of freedom oscillator with a bilateral elastic stop"
PAPER_AUTHORS = (("E. H.", "Moussi"), ("S.", "Bellizzi"), ("B.", "Cochelin"), ("I.", "Nistor"))  # (given, family)
PAPER_REFERENCE = ", ".join(f"{given} {family}" for given, family in PAPER_AUTHORS) + ", " + PAPER_TITLE
_REPO_ROOT = Path(__file__).resolve().parents[2]
# Keys of the configuration's ``metadata`` section copied verbatim into every dataset's global attributes.
METADATA_ATTRIBUTES = (
    "institution",
    "project",
    "naming_authority",
    "processing_level",
    "comment",
    "acknowledgment",
    "license",
    "creator_name",
    "creator_type",
    "creator_email",
    "creator_url",
    "creator_institution",
    "publisher_name",
    "publisher_type",
    "publisher_email",
    "publisher_url",
    "publisher_institution",
)


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(
            ["git", "-C", str(_REPO_ROOT), *args], capture_output=True, text=True, check=True, timeout=10
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None


#: Global attributes that name the git commit and its date: they change with every commit even
#: when no number does (``nnmstop.pipeline.verify`` leaves them out of its "identical data" digest).
PROVENANCE_ATTRIBUTES = ("source", "history", "date_created")


def provenance() -> dict:
    """Git commit and a deterministic creation date (ISO 8601, UTC).

    ``date_created`` is ``SOURCE_DATE_EPOCH`` if set, else the commit date of HEAD,
    else the Unix epoch: it never depends on when the pipeline ran.
    """
    commit = _git("rev-parse", "HEAD") or "unknown"
    epoch = os.environ.get("SOURCE_DATE_EPOCH") or _git("log", "-1", "--format=%ct") or "0"
    date = _dt.datetime.fromtimestamp(int(epoch), tz=_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    return {"commit": commit, "date_created": date}


def global_attributes(title: str, summary: str, keywords: str = "", metadata: dict | None = None) -> dict:
    """The CF/ACDD global attributes shared by every dataset of the pipeline.

    Parameters
    ----------
    title, summary, keywords
        What the dataset holds (ACDD ``title``, ``summary``; ``keywords`` is appended to the
        pipeline's own keywords).
    metadata
        The configuration's ``metadata`` section (institution, project, creator and publisher,
        naming authority, ...); its keys listed in :data:`METADATA_ATTRIBUTES` are copied as they are.
        Without it only the attributes that describe the computation are written.
    """
    prov = provenance()
    attrs = {
        "Conventions": "CF-1.10, ACDD-1.3",
        "title": title,
        "summary": summary,
        "keywords": ", ".join(
            filter(None, ["nonlinear normal modes", "vibro-impact", "elastic stop", "harmonic balance", keywords])
        ),
        "date_created": prov["date_created"],
        "source": f"nnmstop {__version__} (git commit {prov['commit']})",
        # No date, host or path: a rebuild of the same commit must give the same bytes.
        "history": (
            f"computed and written by nnmstop {__version__} (git commit {prov['commit']}), nnmstop.netcdf.write_dataset"
        ),
        "references": PAPER_REFERENCE,
        # No variable has a CF standard name (CF defines none for these quantities); the
        # attribute names the table such names would come from, as ACDD asks: the version the
        # pinned compliance-checker ships, so checking needs no download.
        "standard_name_vocabulary": "CF Standard Name Table v93",
    }
    attrs.update({key: (metadata or {})[key] for key in METADATA_ATTRIBUTES if key in (metadata or {})})
    return attrs


def dataset_id(path: str | Path) -> str:
    """ACDD ``id`` of the dataset written to ``path``: its place under ``results/`` without suffix.

    ``results/hbm/nnm2.nc`` gives ``hbm/nnm2``; a file outside a ``results`` folder gives its
    stem. The id never holds the absolute path, so it is the same on every machine.
    """
    parts = Path(path).with_suffix("").parts
    if "results" in parts:
        last = len(parts) - 1 - parts[::-1].index("results")
        return "/".join(parts[last + 1 :])
    return parts[-1]


def _coverage_content_type(var: xr.DataArray, coordinate: bool) -> str:
    # ACDD 1.3 vocabulary: coordinates are "coordinate", flags "qualityInformation" and every
    # other variable holds computed results, "modelResult".
    if coordinate:
        return "coordinate"
    if "flag_values" in var.attrs or "flag_meanings" in var.attrs:
        return "qualityInformation"
    return "modelResult"


def cf_variable(dims, values, long_name: str, units: str = "1", *, dtype=float, fill_value=None, **extra) -> tuple:
    """A labelled variable ``(dims, array, attrs)`` for :class:`xarray.Dataset`.

    Parameters
    ----------
    dims : str or tuple of str
        Dimension name(s) of the variable.
    values : array_like
        Its values, converted to ``dtype`` (``None`` keeps their own type, e.g. strings).
    long_name, units : str
        CF attributes; ``units`` is ``"1"`` for a dimensionless quantity.
    fill_value : float, optional
        For a variable where some values are legitimately missing (a case that failed in a study):
        non-finite floats become ``fill_value`` and the attribute ``_FillValue`` names it, so a reader
        gets NaN back and never a number that looks valid.
    **extra
        Further attributes, in order after ``long_name`` and ``units``.
    """
    values = np.asarray(values) if dtype is None else np.asarray(values, dtype=dtype)
    attrs = {"long_name": long_name, "units": units, **extra}
    if fill_value is not None and np.issubdtype(values.dtype, np.floating):
        missing = ~np.isfinite(values)
        if missing.any():
            values = np.where(missing, fill_value, values)
        attrs["_FillValue"] = fill_value
    return dims, values, attrs


def flag_variable(dims, values, long_name: str, meanings: str, **extra) -> tuple:
    """A 0/1 flag variable ``(dims, int8 values, attrs)`` with CF ``flag_values``/``flag_meanings``.

    ``meanings`` names the two values in order, e.g. ``"unstable stable"``.
    """
    flags = np.asarray(values).astype(np.int8)
    return cf_variable(
        dims,
        flags,
        long_name,
        "1",
        dtype=None,
        flag_values=np.array([0, 1], dtype=np.int8),
        flag_meanings=meanings,
        **extra,
    )


def check_labelled(ds: xr.Dataset) -> None:
    """Raise ``ValueError`` if a variable lacks ``long_name``/``units`` or holds NaN/inf (NaN allowed only where
    the variable declares a fill value for values not computed, :func:`may_be_missing`)."""
    for name, var in {**ds.coords, **ds.data_vars}.items():
        missing = [a for a in ("long_name", "units") if a not in var.attrs]
        if missing:
            raise ValueError(f"variable {name!r} lacks the attribute(s) {missing}")
        values = np.asarray(var.values)
        if np.issubdtype(var.dtype, np.number) and may_be_missing(var.variable):
            values = values[~np.isnan(values)]
        if np.issubdtype(var.dtype, np.number) and not np.all(np.isfinite(values)):
            raise ValueError(f"variable {name!r} holds NaN or infinite values; refusing to write the dataset")


def write_dataset(
    ds: xr.Dataset,
    path: str | Path,
    title: str,
    summary: str,
    keywords: str = "",
    metadata: dict | None = None,
    *,
    kind: str,
) -> Path:
    """Describe ``ds`` from the variable catalogue, add the global attributes and write it atomically to ``path``.

    ``kind`` names the dataset's layout in :mod:`nnmstop.catalogue`: every variable gets its ``long_name``,
    ``units`` and flag attributes from there, and a variable the kind does not list, other dimensions, a
    missing required variable or a NaN where the catalogue allows none are refused
    (:func:`nnmstop.catalogue.describe`).

    Existing global attributes of ``ds`` (model parameters, settings) are kept, except those this function
    writes (title, summary, id, history, ...: they may come from an input file), and so is a
    ``coverage_content_type`` a variable already carries; the others get one (``coordinate``,
    ``qualityInformation`` for flags, ``modelResult``). ``metadata`` is the configuration's
    ``metadata`` section (see :func:`global_attributes`).

    Raises
    ------
    ValueError
        If a variable is unlabelled or holds NaN or infinite values.
    nnmstop.atomic.OutputWriteError
        If the file system refuses the file (no space left, permission, ...): no file is left behind.
    """
    described_ds = describe(ds, kind)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    out = described_ds.copy()
    # Zero-length dimensions read back from NetCDF-4 are marked unlimited in the encoding, as
    # a set: written unlimited, their order in the file would follow string hashing.
    out.encoding = {k: v for k, v in out.encoding.items() if k != "unlimited_dims"}
    # The attributes written here describe this file; those of the same name that ``ds`` carries over
    # from an input it was read from (a stage's title, id) are replaced. The rest (physics, settings) stay.
    described = {**global_attributes(title, summary, keywords, metadata), "id": dataset_id(path)}
    out.attrs = {**described, **{key: value for key, value in described_ds.attrs.items() if key not in described}}
    for name in out.variables:
        var = out[name]
        var.attrs.setdefault("coverage_content_type", _coverage_content_type(var, name in out.coords))
    encoding = {name: {"zlib": False} for name in out.data_vars}
    # CF: a coordinate variable holds no missing values, so it gets no _FillValue (xarray's default on floats)
    encoding.update({name: {"_FillValue": None} for name in out.coords if name in out.dims})
    with atomic_output(path) as tmp:
        out.to_netcdf(tmp, format="NETCDF4", engine="netcdf4", encoding=encoding)
    return path


def may_be_missing(variable: xr.Variable) -> bool:
    """Whether ``variable`` (read with CF decoding) may hold NaN: only where its file declares a
    finite ``_FillValue`` (a documented fill value, see :func:`cf_variable`) for values not computed.

    Every other floating-point variable must be finite: :func:`write_dataset` refuses NaN and
    infinity, so one in a file means the file was altered or damaged.
    """
    fill = variable.encoding.get("_FillValue", variable.attrs.get("_FillValue"))
    try:
        return fill is not None and bool(np.isfinite(fill))
    except TypeError:
        return False


def non_finite_variables(ds: xr.Dataset) -> dict[str, int]:
    """Variables of ``ds`` (read from a file) holding NaN or infinite values where they must be
    finite (:func:`may_be_missing`), with the number of such values."""
    found = {}
    for name, variable in ds.variables.items():
        bad = _non_finite_mask(variable)
        if bad is not None and bad.any():
            found[str(name)] = int(bad.sum())
    return found


def _non_finite_mask(variable) -> np.ndarray | None:
    """Where a floating-point variable holds NaN or infinity it must not (None for other types)."""
    if not (np.issubdtype(variable.dtype, np.floating) or np.issubdtype(variable.dtype, np.complexfloating)):
        return None
    values = np.asarray(variable.values)
    bad = ~np.isfinite(values)
    if may_be_missing(variable):
        bad &= ~np.isnan(values)
    return bad


def open_checked(path: str | Path) -> xr.Dataset:
    """Load the NetCDF file at ``path`` into memory and close it; ``ValueError`` naming the file if
    it is missing, empty, truncated or not NetCDF (with the reader's own message)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"no dataset at {path}")
    if path.stat().st_size == 0:
        raise ValueError(f"{path} is empty (0 bytes): not a NetCDF dataset")
    try:
        with xr.open_dataset(path) as ds:
            return ds.load()
    except Exception as error:  # the readers raise OSError, RuntimeError, ValueError, KeyError...
        raise ValueError(f"{path} cannot be read as NetCDF ({type(error).__name__}: {error})") from error


def read_dataset(path: str | Path, required: Iterable[str] = (), expected: Mapping | None = None) -> xr.Dataset:
    """Load the NetCDF dataset at ``path`` into memory and close the file.

    Parameters
    ----------
    path : str or Path
        The dataset (an input of a task).
    required : iterable of str
        Variables or coordinates the caller reads; a dataset without one of them is refused.
    expected : mapping, optional
        Settings the dataset must have been computed with (see :func:`check_up_to_date`).

    Raises
    ------
    ValueError
        If the file does not exist or cannot be read, lacks a required variable, holds NaN or
        infinite values in a variable that must be finite (:func:`may_be_missing`), holds orbits
        that do not satisfy their equations to the accuracy it states
        (:func:`nnmstop.stored_accuracy.check_orbits`), or is stale; the message names the file
        (and the variable, and the point).
    """
    from nnmstop.stored_accuracy import check_orbits

    path = Path(path)
    loaded = open_checked(path)
    missing = [name for name in required if name not in loaded.variables]
    if missing:
        raise ValueError(f"{path} lacks the variable(s) {missing}; it holds {sorted(map(str, loaded.variables))}")
    check_finite_values(loaded, path)
    check_orbits(loaded, path)
    if expected:
        check_up_to_date(loaded, expected, source=path)
    return loaded


def check_finite_values(ds: xr.Dataset, source) -> None:
    """Refuse NaN or infinity in a variable of ``ds`` that must hold numbers (:func:`may_be_missing`), naming
    ``source``, each such variable and its first such point."""
    non_finite = non_finite_variables(ds)
    if non_finite:
        listed = []
        for name, count in sorted(non_finite.items()):
            variable = ds.variables[name]
            where = ""
            if "point" in variable.dims:
                bad = _non_finite_mask(variable)
                axis = variable.dims.index("point")
                first = np.flatnonzero(bad.any(axis=tuple(a for a in range(bad.ndim) if a != axis)))
                where = f", first at point {int(first[0])}" if first.size else ""
            listed.append(f"{name} ({count} values{where})")
        raise ValueError(
            f"{source} holds NaN or infinite values where numbers must be: {', '.join(listed)}; rebuild it"
        )


def check_up_to_date(
    ds: xr.Dataset, expected: Mapping, source: str | Path = "the dataset", rtol: float = 1e-12
) -> None:
    """Refuse a dataset computed with other settings than ``expected`` (a stale input).

    Parameters
    ----------
    ds : xarray.Dataset
        A dataset read back from a file; its global attributes record the settings it was computed with.
    expected : mapping
        Attribute name -> the configured value: numbers are compared with relative tolerance
        ``rtol`` (a float read back from NetCDF is the float written, so only round-off of a
        conversion is allowed), anything else must be equal.
    source : str or Path
        Where ``ds`` came from, for the message.

    Raises
    ------
    ValueError
        Naming the first attribute that is missing or differs, its stored and its configured value.
    """
    for key, value in expected.items():
        stored = ds.attrs.get(key)
        if stored is None:
            raise ValueError(f"{source} does not record {key!r} (configured {value!r}); rebuild it")
        if isinstance(value, (int, float, np.number)) and not isinstance(value, bool):
            try:
                same = bool(np.isclose(float(stored), float(value), rtol=rtol, atol=0))
            except (TypeError, ValueError):  # a text attribute where a number is configured
                same = False
        else:
            same = str(stored) == str(value)
        if not same:
            shown = stored.item() if isinstance(stored, np.generic) else stored  # 0.1, not np.float64(0.1)
            raise ValueError(
                f"{source}: {key} = {shown!r} in the dataset but {value!r} in the configuration "
                "(stale dataset); rebuild it"
            )
