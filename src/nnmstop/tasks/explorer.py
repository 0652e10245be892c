"""Task of ``workflow/rules/explorer.smk``: the offline explorer page (:mod:`nnmstop.explorer`)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["explorer"]


def explorer(config: dict, inputs: dict, outputs: dict) -> Path:
    """Write ``outputs["page"]`` (``dist/explorer.html``) from the branch datasets of the rule.

    Parameters
    ----------
    config : dict
        Section ``explorer`` (optional): :class:`nnmstop.explorer.extract.ExplorerSettings`; ``structure`` (and
        ``model``) where the exact family is a structure's (``exact_one_stop``), whose orbits are rebuilt on it.
    inputs : dict
        One list of dataset paths per kind of branch (``regularized``, ``exact``, ...; the keys of
        :data:`nnmstop.explorer.extract.KINDS`) and ``manifest`` (``results/MANIFEST.sha256``); with the atlas,
        ``atlas`` (its datasets) and ``atlas_slices`` (their slices).
    outputs : dict
        ``page``: the HTML file to write.
    """
    from nnmstop.explorer.extract import KINDS, ExplorerSettings
    from nnmstop.explorer.page import build_explorer

    unknown = sorted(set(inputs) - set(KINDS) - {"manifest", "mass", "stiffness", "atlas", "atlas_slices"})
    if unknown:
        raise ValueError(f"explorer inputs {unknown} are no kind of branch; known kinds: {sorted(KINDS)}")
    branches = {
        kind: [inputs[kind]] if isinstance(inputs[kind], (str, Path)) else list(inputs[kind])
        for kind in KINDS
        if kind in inputs
    }
    structure = None
    if "exact_one_stop" in branches:  # the exact family of a structure of one's own: its orbits are rebuilt on it
        from nnmstop.settings import structure_from_config

        structure = structure_from_config(config)
    atlases = {}
    slices = [Path(p) for p in _listed(inputs.get("atlas_slices", []))]
    for path in _listed(inputs.get("atlas", [])):
        stem = Path(path).stem  # results/atlas/<map>.nc; its slices are results/atlas/<map>/slice_<k>.nc
        mine = sorted((p for p in slices if p.parent.name == stem), key=lambda p: int(p.stem.split("_")[-1]))
        atlases[str(path)] = [str(p) for p in mine]
    settings = ExplorerSettings.from_config(config.get("explorer"), structure)
    return build_explorer(branches, inputs["manifest"], outputs["page"], settings, atlases=atlases)


def _listed(value) -> list:
    return [value] if isinstance(value, (str, Path)) else list(value)


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {f.__name__: f for f in (explorer,)}
