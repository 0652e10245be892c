"""Writing labelled branches to NetCDF: CF/ACDD metadata, determinism, atomicity.

Every dataset of the pipeline goes through :func:`write_dataset`, which

* checks that every variable and coordinate carries ``long_name`` and ``units``,
* refuses NaN or infinite values (a failed computation never leaves a dataset),
* adds the CF-1.10 / ACDD-1.3 global attributes (``date_created`` comes from
  ``SOURCE_DATE_EPOCH`` or the commit date of the git checkout, never the clock),
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

from . import __version__

__all__ = ["PAPER_REFERENCE", "provenance", "global_attributes", "flag_variable", "check_labelled", "write_dataset"]

PAPER_REFERENCE = (
    "E. H. Moussi, S. Bellizzi, B. Cochelin, I. Nistor, Nonlinear normal modes of a two degree of "
    "freedom oscillator with a bilateral elastic stop"
)
_REPO_ROOT = Path(__file__).resolve().parents[2]


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(
            ["git", "-C", str(_REPO_ROOT), *args], capture_output=True, text=True, check=True, timeout=10
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None


def provenance() -> dict:
    """Git commit and a deterministic creation date (ISO 8601, UTC).

    ``date_created`` is ``SOURCE_DATE_EPOCH`` if set, else the commit date of HEAD,
    else the Unix epoch: it never depends on when the pipeline ran.
    """
    commit = _git("rev-parse", "HEAD") or "unknown"
    epoch = os.environ.get("SOURCE_DATE_EPOCH") or _git("log", "-1", "--format=%ct") or "0"
    date = _dt.datetime.fromtimestamp(int(epoch), tz=_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    return {"commit": commit, "date_created": date}


def global_attributes(title: str, summary: str, keywords: str = "") -> dict:
    """The CF/ACDD global attributes shared by every dataset of the pipeline."""
    prov = provenance()
    return {
        "Conventions": "CF-1.10, ACDD-1.3",
        "title": title,
        "summary": summary,
        "keywords": ", ".join(
            filter(None, ["nonlinear normal modes", "vibro-impact", "elastic stop", "harmonic balance", keywords])
        ),
        "date_created": prov["date_created"],
        "source": f"nnmstop {__version__} (git commit {prov['commit']})",
        "references": PAPER_REFERENCE,
        "creator_name": "nnmstop developers",
        "license": "MIT",
    }


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


def write_dataset(ds: xr.Dataset, path: str | Path, title: str, summary: str, keywords: str = "") -> Path:
    """Validate ``ds``, add the global attributes and write it atomically to ``path``.

    Existing global attributes of ``ds`` (model parameters, settings) are kept.
    """
    check_labelled(ds)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    out = ds.copy()
    # Zero-length dimensions read back from NetCDF-4 are marked unlimited in the encoding, as
    # a set: written unlimited, their order in the file would follow string hashing.
    out.encoding = {k: v for k, v in out.encoding.items() if k != "unlimited_dims"}
    out.attrs = {**global_attributes(title, summary, keywords), **ds.attrs}
    encoding = {name: {"zlib": False} for name in out.data_vars}
    tmp = path.with_name(path.name + ".tmp")
    out.to_netcdf(tmp, format="NETCDF4", engine="netcdf4", encoding=encoding)
    os.replace(tmp, path)
    return path
