"""Task of ``workflow/rules/explorer.smk``: the offline explorer page (:mod:`nnmstop.explorer`)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["explorer"]


def explorer(config: dict, inputs: dict, outputs: dict) -> Path:
    """Write ``outputs["page"]`` (``dist/explorer.html``) from the branch datasets of the rule.

    Parameters
    ----------
    config : dict
        Section ``explorer`` (optional): :class:`nnmstop.explorer.extract.ExplorerSettings`.
    inputs : dict
        One list of dataset paths per kind of branch (``regularized``, ``exact``, ...; the keys of
        :data:`nnmstop.explorer.extract.KINDS`) and ``manifest`` (``results/MANIFEST.sha256``).
    outputs : dict
        ``page``: the HTML file to write.
    """
    from nnmstop.explorer.extract import KINDS, ExplorerSettings
    from nnmstop.explorer.page import build_explorer

    unknown = sorted(set(inputs) - set(KINDS) - {"manifest"})
    if unknown:
        raise ValueError(f"explorer inputs {unknown} are no kind of branch; known kinds: {sorted(KINDS)}")
    branches = {
        kind: [inputs[kind]] if isinstance(inputs[kind], (str, Path)) else list(inputs[kind])
        for kind in KINDS
        if kind in inputs
    }
    return build_explorer(
        branches, inputs["manifest"], outputs["page"], ExplorerSettings.from_config(config.get("explorer"))
    )


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {f.__name__: f for f in (explorer,)}
