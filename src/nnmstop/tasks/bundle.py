"""Task of ``workflow/rules/bundle.smk``: the result bundle to share and cite.

One deterministic zip archive (``dist/nnmstop-results.zip``) with the datasets, figures,
manifest, configuration, ``environment.lock``, the workflow files, ``CITATION.cff`` and an
RO-Crate that describes the run; the work is done by :func:`nnmstop.pipeline.bundle.build_bundle`.
The task gets the whole configuration: the bundle stores it as ``config/config.yaml``.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["bundle"]


def _as_list(value) -> list:
    return [value] if isinstance(value, (str, Path)) else list(value)


def bundle(config: dict, inputs: dict, outputs: dict) -> Path:
    """Write ``outputs["bundle"]`` from the named inputs of the rule.

    Parameters
    ----------
    config : dict
        The whole validated configuration (stored in the bundle; its ``metadata`` section
        describes the crate and the citation).
    inputs : dict
        ``datasets``, ``figures``, ``workflow_files`` (lists of paths), ``manifest`` (the build's manifests:
        a path or a list), ``environment_lock`` and ``citation`` (the repository's ``CITATION.cff``).
    outputs : dict
        ``bundle``: the zip archive to write.
    """
    from nnmstop.pipeline.bundle import build_bundle

    return build_bundle(
        config,
        datasets=_as_list(inputs["datasets"]),
        figures=_as_list(inputs["figures"]),
        manifest=_as_list(inputs["manifest"]),
        environment_lock=inputs["environment_lock"],
        workflow_files=_as_list(inputs["workflow_files"]),
        output=outputs["bundle"],
        citation_file=inputs["citation"],
    )


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {f.__name__: f for f in (bundle,)}
