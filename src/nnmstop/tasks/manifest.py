"""Task of ``workflow/rules/manifest.smk``: the SHA-256 manifest of the paper's datasets.

``results/MANIFEST.sha256`` lists every dataset behind the paper's figures in the format of
``sha256sum -c``, one line per file, sorted by path and with the paths as the rule gives them
(relative to the working directory), so that a copy of the results can be checked with
standard tools and the manifest itself is byte-reproducible. Each dataset is read first by the
reader of every task (:func:`nnmstop.netcdf.read_dataset`): a dataset that is unreadable, holds NaN
where numbers must be or orbits that do not satisfy their equations gets no line, and no manifest.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from nnmstop.atomic import atomic_output
from nnmstop.netcdf import read_dataset

__all__ = ["dataset_manifest"]


def dataset_manifest(config: dict, inputs: dict, outputs: dict) -> Path:
    """Write the manifest ``outputs["manifest"]`` of the datasets ``inputs["datasets"]``.

    Parameters
    ----------
    config : dict
        Unused: the manifest depends on the files alone.
    inputs : dict
        ``datasets``: one path or a list of paths.
    outputs : dict
        ``manifest``: the file to write.

    Returns
    -------
    Path
        The manifest.

    Raises
    ------
    ValueError
        If a dataset cannot be read, holds NaN or infinity where numbers must be, or holds orbits that do not
        satisfy their equations (the message names the file).
    """
    datasets = inputs["datasets"]
    paths = [datasets] if isinstance(datasets, (str, Path)) else list(datasets)
    lines = []
    for path in sorted(map(str, paths)):
        data = Path(path).read_bytes()
        if path.endswith(".nc"):
            read_dataset(path)  # ValueError naming the file, the variable and the point
        lines.append(f"{hashlib.sha256(data).hexdigest()}  {path}\n")
    out = Path(outputs["manifest"])
    with atomic_output(out) as tmp:
        tmp.write_text("".join(lines))
    return out


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {f.__name__: f for f in (dataset_manifest,)}
