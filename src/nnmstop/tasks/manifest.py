"""Task of ``workflow/rules/manifest.smk``: the SHA-256 manifest of the paper's datasets.

``results/MANIFEST.sha256`` lists every dataset behind the paper's figures in the format of
``sha256sum -c``, one line per file, sorted by path and with the paths as the rule gives them
(relative to the working directory), so that a copy of the results can be checked with
standard tools and the manifest itself is byte-reproducible.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from nnmstop.atomic import atomic_output

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
    """
    datasets = inputs["datasets"]
    paths = [datasets] if isinstance(datasets, (str, Path)) else list(datasets)
    lines = [f"{hashlib.sha256(Path(path).read_bytes()).hexdigest()}  {path}\n" for path in sorted(map(str, paths))]
    out = Path(outputs["manifest"])
    with atomic_output(out) as tmp:
        tmp.write_text("".join(lines))
    return out


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {f.__name__: f for f in (dataset_manifest,)}
