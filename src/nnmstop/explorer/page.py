"""The explorer page: one self-contained HTML file from the branch records of :mod:`.extract`.

:func:`build_explorer` reads the datasets, and :func:`render_page` fills the template
``static/explorer.html`` with the style, the vendored plotting library (``vendor/``, pinned in
:data:`PLOTLY`), the page's scripts (``static/*.js``) and the data as JSON, every numeric array
packed as base64 of its little-endian bytes. Nothing is fetched when the page is viewed.
"""

from __future__ import annotations

import base64
import hashlib
import json
import re
from importlib import resources
from pathlib import Path

import numpy as np

from nnmstop.atomic import atomic_output
from nnmstop.explorer.extract import ExplorerSettings, extract_atlas, extract_branch, read_manifest

__all__ = ["PLOTLY", "SCRIPTS", "encode", "render_page", "build_explorer"]

#: The vendored plotting library: npm package, version, file and its SHA-256.
PLOTLY = {
    "package": "plotly.js-basic-dist-min",
    "version": "4.1.1",
    "file": "vendor/plotly-basic.min.js",
    "license": "vendor/LICENSE-plotly.js.txt",
    "sha256": "99784e3abfb07b142a15e521a439e6d9addceadb3f79553fd24c72774f0649ba",
}
#: The page's own scripts, in loading order.
SCRIPTS = ("static/synthesis.js", "static/views.js", "static/explorer.js", "static/atlas.js")
# numpy dtype kind and size -> the typed array the page decodes into
_TYPES = {("f", 4): "f32", ("f", 8): "f64", ("i", 1): "i8", ("u", 1): "u8", ("i", 2): "i16", ("i", 4): "i32"}
_LITTLE_ENDIAN = {"f32": "<f4", "f64": "<f8", "i8": "i1", "u8": "u1", "i16": "<i2", "i32": "<i4"}


def _packed(array: np.ndarray) -> dict:
    """A numeric array as ``{"dtype", "shape", "b64"}``; booleans go as int8, wider integers as int32."""
    array = np.asarray(array)
    if array.dtype.kind == "b":
        array = array.astype(np.int8)
    if array.dtype.kind in "iu" and (
        array.dtype.itemsize > 4 or (array.dtype.kind, array.dtype.itemsize) not in _TYPES
    ):
        if array.size and (array.min() < -(2**31) or array.max() >= 2**31):
            raise ValueError("integer values beyond int32 cannot be packed")
        array = array.astype(np.int32)
    name = _TYPES.get((array.dtype.kind, array.dtype.itemsize))
    if name is None:
        raise TypeError(f"cannot pack an array of dtype {array.dtype}")
    if array.dtype.kind == "f" and not np.all(np.isfinite(array)):
        raise ValueError("the explorer's data must be finite")
    data = np.ascontiguousarray(array, dtype=_LITTLE_ENDIAN[name])
    return {"dtype": name, "shape": list(data.shape), "b64": base64.b64encode(data.tobytes()).decode("ascii")}


def encode(value):
    """JSON-ready copy of ``value``: numpy arrays packed (:func:`_packed`), numpy scalars as Python numbers."""
    if isinstance(value, dict):
        return {str(k): encode(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [encode(v) for v in value]
    if isinstance(value, np.ndarray):
        return _packed(value)
    if isinstance(value, np.generic):
        return value.item()
    return value


def _package_text(name: str) -> str:
    return resources.files("nnmstop.explorer").joinpath(name).read_text(encoding="utf-8")


def plotly_source() -> str:
    """The vendored plotly.js, after checking it is the pinned file."""
    text = _package_text(PLOTLY["file"])
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()
    if digest != PLOTLY["sha256"]:
        raise ValueError(
            f"{PLOTLY['file']} has SHA-256 {digest}, not the pinned {PLOTLY['sha256']} (version {PLOTLY['version']})"
        )
    return text


def _inline_script(text: str, name: str) -> str:
    if re.search(r"</script", text, flags=re.IGNORECASE):
        raise ValueError(f"{name} holds '</script' and cannot be inlined")
    return text


def render_page(data: dict) -> str:
    """The HTML page for the explorer's ``data`` (branches and build information)."""
    payload = json.dumps(encode(data), separators=(",", ":"), allow_nan=False).replace("<", "\\u003c")
    parts = {
        "STYLE": _package_text("static/explorer.css"),
        "PLOTLY": _inline_script(plotly_source(), PLOTLY["file"]),
        "SCRIPTS": "\n".join(_inline_script(_package_text(name), name) for name in SCRIPTS),
        "DATA": payload,
        "TITLE": "nnmstop explorer",
    }
    template = _package_text("static/explorer.html")
    return re.sub(r"\{\{([A-Z]+)\}\}", lambda m: parts[m.group(1)], template)


def build_explorer(
    branches: dict, manifest, output, settings: ExplorerSettings | None = None, root=".", atlases: dict | None = None
) -> Path:
    """Write the explorer page ``output`` and return its path.

    Parameters
    ----------
    branches
        ``{kind: [dataset paths]}``, kinds of :data:`nnmstop.explorer.extract.KINDS`; paths relative
        to ``root`` (the page shows them, with their SHA-256).
    manifest
        ``results/MANIFEST.sha256``: a listed dataset must match its SHA-256 there.
    output
        The HTML file to write (e.g. ``dist/explorer.html``), through :func:`nnmstop.atomic.atomic_output`
        (a failed write names its path and the reason, and leaves no partial file).
    atlases
        ``{atlas dataset path: [its slice dataset paths]}``: the maps of the atlas, shown below the branches
        (:func:`nnmstop.explorer.extract.extract_atlas`).
    """
    settings = settings or ExplorerSettings()
    listed = read_manifest(Path(root) / manifest)
    records = [
        extract_branch(kind, path, listed, settings, root=root) for kind, paths in branches.items() for path in paths
    ]
    if not records:
        raise ValueError("the explorer needs at least one branch dataset")
    data = {
        "branches": records,
        "atlases": [extract_atlas(path, slices, listed, root=root) for path, slices in (atlases or {}).items()],
        "settings": {"time_samples": settings.time_samples},
        "manifest": Path(manifest).as_posix(),
        "plotly": {key: PLOTLY[key] for key in ("package", "version")},
    }
    output = Path(output)
    with atomic_output(output) as partial:
        partial.write_text(render_page(data), encoding="utf-8")
    return output
