"""Task of ``workflow/rules/docs.smk``: the documentation pages generated from the datasets.

``docs/results.md`` (:func:`nnmstop.docpages.results.results_page`) and the front-page figure
``docs/nnm1_frequency_energy.png`` (a copy of ``paper_figures/fig02.png``), both committed.
"""

from __future__ import annotations

import logging
import shutil
from pathlib import Path

from nnmstop.atomic import atomic_output

__all__ = ["docs"]

logger = logging.getLogger("nnmstop.tasks.docs")


def docs(config: dict, inputs: dict, outputs: dict) -> None:
    """Write ``outputs["results"]`` from the datasets and copy ``inputs["figure"]`` to ``outputs["figure"]``.

    Parameters
    ----------
    config : dict
        Section ``model`` (the linear limits on the page).
    inputs : dict
        One entry per dataset of :data:`nnmstop.docpages.results.RESULT_DATASETS` (same names; the
        switched branches only where the build has them), and ``figure``: the PNG shown on the front page and in README.
    outputs : dict
        ``results``: the page (``docs/results.md``); ``figure``: the copy of the figure.
    """
    from nnmstop.docpages.results import RESULT_DATASETS, results_page
    from nnmstop.models.two_dof import ModelParameters
    from nnmstop.pipeline.verify import data_digest

    paths = {name: Path(inputs[name]) for name in RESULT_DATASETS if name in inputs}
    results_dir = paths["nnm1"].parents[len(Path(RESULT_DATASETS["nnm1"]).parts) - 1]
    for name, path in paths.items():
        if path != results_dir / RESULT_DATASETS[name]:
            raise ValueError(f"input {name!r} must be {results_dir / RESULT_DATASETS[name]}, got {path}")
    digests = {RESULT_DATASETS[name]: data_digest(path) for name, path in paths.items()}
    page = results_page(results_dir, ModelParameters(**config["model"]), digests)  # reads each with read_dataset
    with atomic_output(outputs["results"]) as partial:
        partial.write_text(page)
    with atomic_output(outputs["figure"]) as partial:
        shutil.copyfile(inputs["figure"], partial)
    logger.info("wrote %s from %d datasets and %s", outputs["results"], len(paths), outputs["figure"])


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {f.__name__: f for f in (docs,)}
