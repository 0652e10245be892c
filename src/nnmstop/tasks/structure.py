"""Tasks of any structure beyond its branches: exact one-impact family, comparison, frequency-energy figures.

They read the sections a rule passes in the shape of the top-level configuration (``structure``,
``exact``, ``compare_count``, ``figures``, ``metadata``); the tube's rules pass its own section so shaped
(:func:`nnmstop.tasks.tube.tube_config`). ``structure_exact``: the exact family of orbits with one impact
per stop side per period (:mod:`nnmstop.exact.ndof`, from the grazing orbit of the first linear mode, its end
confirmed); ``structure_compare``: exact against regularized NNM1 at matched energies, on the exact family's
backbone (before its first internal resonance, :func:`nnmstop.exact.dataset.one_stop_backbone`)
(:mod:`nnmstop.compare.structure_branches`); ``structure_figure``: the figures of
:mod:`nnmstop.figures.structure`.
"""

from __future__ import annotations

from nnmstop.api import exact_family_dataset, switching_family_dataset, uses_quarter_period
from nnmstop.netcdf import read_dataset, write_dataset
from nnmstop.settings import structure_from_config

__all__ = ["structure_exact", "structure_compare", "structure_figure", "study_figure"]


def structure_exact(config, inputs, outputs, keywords: str = ""):
    """Exact NNM1 of the non-smooth structure with one impact per stop side per period."""
    from nnmstop.exact.ndof import follow_one_stop_family

    structure = structure_from_config(config)
    if not uses_quarter_period(structure):
        return _switching_exact(structure, config, outputs, keywords)
    family = follow_one_stop_family(
        structure, step=config["exact"]["step"], max_points=config["exact"]["max_points"], confirm=True
    )
    ds = exact_family_dataset(structure, family)
    write_dataset(
        ds,
        outputs["dataset"],
        title=f"Exact NNM1 of the {structure.n_dofs}-DOF structure with a bilateral stop",
        summary="Exact periodic orbits of the non-smooth (piecewise-linear) structure with one impact on each side "
        "of its stop per period, from the grazing orbit of its first linear mode; closed-form phases (matrix "
        f"exponentials). Internal resonance: {ds.attrs['internal_resonance']}. The family ends because "
        f"{family.end_reason}.",
        keywords=keywords,
        metadata=config.get("metadata"),
        kind="one_stop_family",
    )


def _switching_exact(structure, config, outputs, keywords: str) -> None:
    """The full-period exact family (one-sided stops, unequal gaps, relative stops), or, for a law that is not
    piecewise linear (a circular clearance), a dataset with no orbit that says why."""
    from nnmstop.exact.switching import follow_switching_family

    try:
        contacts_ok, reason = True, ""
        for stop in structure.stops:
            stop.contacts()
    except ValueError as err:
        contacts_ok, reason = False, str(err)
    if contacts_ok:
        family = follow_switching_family(
            structure, step=config["exact"]["step"], max_points=config["exact"]["max_points"]
        )
        ds = switching_family_dataset(structure, family)
        summary = (
            "Exact periodic orbits of the non-smooth (piecewise-linear) structure over full periods, one impact per "
            "contact struck, from next to the grazing orbit of its first linear mode at the first contact it "
            f"reaches; closed-form phases (matrix exponentials). Phases: {ds.attrs['sequences']}. The family ends "
            f"because {family.end_reason}."
        )
    else:
        ds = switching_family_dataset(structure, None, reason)
        summary = f"No exact orbits: {reason}."
    write_dataset(
        ds,
        outputs["dataset"],
        title=f"Exact NNM1 of the {structure.n_dofs}-DOF structure ({', '.join(s.label for s in structure.stops)})",
        summary=summary,
        keywords=keywords,
        metadata=config.get("metadata"),
        kind="switching_family",
    )


def structure_compare(config, inputs, outputs, keywords: str = ""):
    """Exact against regularized NNM1 at matched energies."""
    from nnmstop.compare.structure_branches import compare_at_energies, like_exact_family
    from nnmstop.exact.dataset import one_stop_backbone

    exact = read_dataset(inputs["exact"])
    if "resonant_mode" in exact:
        exact = one_stop_backbone(exact)  # not its internal resonance: see the dataset
    regularized = read_dataset(inputs["nnm1"])
    ds = compare_at_energies(
        exact.energy.values,
        exact.frequency.values,
        regularized.energy.values,
        regularized.frequency.values,
        config["compare_count"],
        segment=regularized.segment.values,
        comparable=like_exact_family(regularized, int(exact.attrs.get("struck_stop", 0))),
    )
    if exact.sizes["orbit"] == 0:  # no exact orbit (a law that is not piecewise linear): say why
        ds.attrs["end_reason"] = f"no exact orbits: {exact.attrs['end_reason']}"
    ds.attrs = {**ds.attrs, **structure_from_config(config).attributes, "harmonics": regularized.attrs["harmonics"]}
    write_dataset(
        ds,
        outputs["dataset"],
        title="Exact against regularized NNM1 of the structure",
        summary="Frequencies of the exact non-smooth and the regularized NNM1 where each branch first reaches "
        "log-spaced energies of their common range.",
        keywords=keywords,
        metadata=config.get("metadata"),
        kind="one_impact_comparison",
    )


def structure_figure(config, inputs, outputs, figure: str):
    """``<prefix>_<figure>.{pdf,png}`` from the structure's datasets (:mod:`nnmstop.figures.structure`)."""
    from nnmstop.figures.structure import draw_structure_figure

    data = {k: read_dataset(v) for k, v in inputs.items()}
    draw_structure_figure(figure, data, config["figures"], outputs["pdf"])


def study_figure(config, inputs, outputs):
    """The tube study's figure: NNM1 backbones (physical units) over gap and stop stiffness."""
    from nnmstop.figures.structure import draw_study_figure

    cases = [read_dataset(path) for path in inputs["cases"]]
    draw_study_figure(cases, config["tube"]["figures"], outputs["pdf"])


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {f.__name__: f for f in (structure_exact, structure_compare, structure_figure)}
