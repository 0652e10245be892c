"""Writing labelled branches to NetCDF: CF/ACDD metadata, determinism, atomicity.

Every dataset of the pipeline goes through :func:`write_dataset`, which

* checks that every variable and coordinate carries ``long_name`` and ``units``,
* refuses NaN or infinite values (a failed computation never leaves a dataset),
* adds the CF-1.10 / ACDD-1.3 global attributes (``date_created`` comes from
  ``SOURCE_DATE_EPOCH`` or the commit date of the git checkout, never the clock; who made and
  publishes the data comes from the configuration's ``metadata`` section),
* gives every variable a ``coverage_content_type`` (ACDD),
* writes to a temporary file and renames it, so an interrupted run leaves no
  partial file under the final name.
"""

from __future__ import annotations

import datetime as _dt
import os
import subprocess
from pathlib import Path

import numpy as np
import xarray as xr

from nnmstop import __version__

__all__ = [
    "PAPER_AUTHORS",
    "PAPER_REFERENCE",
    "PAPER_TITLE",
    "METADATA_ATTRIBUTES",
    "provenance",
    "global_attributes",
    "dataset_id",
    "flag_variable",
    "check_labelled",
    "write_dataset",
]

PAPER_TITLE = "Nonlinear normal modes of a two degree of freedom oscillator with a bilateral elastic stop"
PAPER_AUTHORS = (("E. H.", "Moussi"), ("S.", "Bellizzi"), ("B.", "Cochelin"), ("I.", "Nistor"))  # (given, family)
PAPER_REFERENCE = ", ".join(f"{given} {family}" for given, family in PAPER_AUTHORS) + ", " + PAPER_TITLE
_REPO_ROOT = Path(__file__).resolve().parents[2]
# Keys of the configuration's ``metadata`` section copied verbatim into every dataset's global attributes.
METADATA_ATTRIBUTES = (
    "institution", "project", "naming_authority", "processing_level", "comment", "acknowledgment", "license",
    "creator_name", "creator_type", "creator_email", "creator_url", "creator_institution",
    "publisher_name", "publisher_type", "publisher_email", "publisher_url", "publisher_institution",
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
#: when no number does (``nnmstop.verify`` leaves them out of its "identical data" digest).
PROVENANCE_ATTRIBUTES = ("source", "history", "date_created")


def provenance() -> dict:
    """Git commit and a deterministic creation date (ISO 8601, UTC).

    ``date_created`` is ``SOURCE_DATE_EPOCH`` if set, else the commit date of HEAD,
    else the Unix epoch: it never depends on when the pipeline ran.
    """
    commit = _git("rev-parse", "HEAD") or "unknown"
    epoch = os.environ.get("SOURCE_DATE_EPOCH") or _git("log", "-1", "--format=%ct") or "0"
    date = _dt.datetime.fromtimestamp(int(epoch), tz=_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
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
        "history": f"computed and written by nnmstop {__version__} (git commit {prov['commit']}), nnmstop.netcdf.write_dataset",
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
        return "/".join(parts[last + 1:])
    return parts[-1]


def _coverage_content_type(var: xr.DataArray, coordinate: bool) -> str:
    # ACDD 1.3 vocabulary: coordinates are "coordinate", flags "qualityInformation" and every
    # other variable holds computed results, "modelResult".
    if coordinate:
        return "coordinate"
    if "flag_values" in var.attrs or "flag_meanings" in var.attrs:
        return "qualityInformation"
    return "modelResult"


def flag_variable(dims, values, long_name: str, meanings: str, **extra) -> tuple:
    """A 0/1 flag variable ``(dims, int8 values, attrs)`` with CF ``flag_values``/``flag_meanings``.

    ``meanings`` names the two values in order, e.g. ``"unstable stable"``.
    """
    attrs = {"long_name": long_name, "units": "1", "flag_values": np.array([0, 1], dtype=np.int8),
             "flag_meanings": meanings, **extra}
    return dims, np.asarray(values).astype(np.int8), attrs


def check_labelled(ds: xr.Dataset) -> None:
    """Raise ``ValueError`` if a variable lacks ``long_name``/``units`` or holds NaN/inf."""
    for name, var in {**ds.coords, **ds.data_vars}.items():
        missing = [a for a in ("long_name", "units") if a not in var.attrs]
        if missing:
            raise ValueError(f"variable {name!r} lacks the attribute(s) {missing}")
        if np.issubdtype(var.dtype, np.number) and not np.all(np.isfinite(var.values)):
            raise ValueError(f"variable {name!r} holds NaN or infinite values; refusing to write the dataset")


def write_dataset(
    ds: xr.Dataset, path: str | Path, title: str, summary: str, keywords: str = "", metadata: dict | None = None
) -> Path:
    """Validate ``ds``, add the global attributes and write it atomically to ``path``.

    Existing global attributes of ``ds`` (model parameters, settings) are kept, except those this
    function writes (title, summary, id, history, ...: they may come from an input file), and so is a
    ``coverage_content_type`` a variable already carries; the others get one (``coordinate``,
    ``qualityInformation`` for flags, ``modelResult``). ``metadata`` is the configuration's
    ``metadata`` section (see :func:`global_attributes`).
    """
    check_labelled(ds)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    out = ds.copy()
    # Zero-length dimensions read back from NetCDF-4 are marked unlimited in the encoding, as
    # a set: written unlimited, their order in the file would follow string hashing.
    out.encoding = {k: v for k, v in out.encoding.items() if k != "unlimited_dims"}
    # The attributes written here describe this file; those of the same name that ``ds`` carries over
    # from an input it was read from (a stage's title, id) are replaced. The rest (physics, settings) stay.
    described = {**global_attributes(title, summary, keywords, metadata), "id": dataset_id(path)}
    out.attrs = {**described, **{key: value for key, value in ds.attrs.items() if key not in described}}
    for name in out.variables:
        var = out[name]
        var.attrs.setdefault("coverage_content_type", _coverage_content_type(var, name in out.coords))
    encoding = {name: {"zlib": False} for name in out.data_vars}
    tmp = path.with_name(path.name + ".tmp")
    out.to_netcdf(tmp, format="NETCDF4", engine="netcdf4", encoding=encoding)
    os.replace(tmp, path)
    return path
