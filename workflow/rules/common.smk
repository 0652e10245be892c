# Paths, configuration slices and input functions shared by the rules. Every folder of the
# workflow's files is named here once; a rule names its outputs with these helpers and its
# inputs with `rules.<rule>.output.<name>`, so a path is written in one place only.

from nnmstop.docpages.paper_table import PAPER_TABLE_DATASETS
from nnmstop.docpages.results import OPTIONAL_DATASETS, RESULT_DATASETS
from nnmstop.docpages.results import STRUCTURE_DATASETS as STRUCTURE_PAGE_DATASETS
from nnmstop.settings import study_settings
from nnmstop.study.error_runtime import sweep_cases
from nnmstop.study.runs import format_number
from nnmstop.study.stiff_cases import stiff_case_parameters
from nnmstop.tasks.tube import circular_hole_config, tube_config
from nnmstop.tasks.tube_plates import plates_circular_config, plates_config


def results(path):
    """A dataset or table under results/."""
    return f"results/{path}"


def paper_figures(path):
    """A figure under paper_figures/."""
    return f"paper_figures/{path}"


def logs(path):
    """The log file of a job, under logs/."""
    return f"logs/{path}"


# The longest chains of the build (the exact family and its comparison; the HBM stages one after
# the other, then the branches switched from them) start first: with two cores, the figure jobs
# then fill the gaps instead of delaying the chains (Snakemake runs higher `priority:` first).
CRITICAL_PATH = 10


def benchmarks(path):
    """The run time and memory of a job (Snakemake `benchmark:`), under benchmarks/runs/."""
    return f"benchmarks/runs/{path}"


def task_config(*sections, **parts):
    """`params: config=...`: the configuration a rule's task reads, and nothing else.

    Each name of `sections` passes that top-level section whole; each keyword passes part of
    a section: the keys it lists, or that a function of the wildcards returns (the rule's own
    branch, say). Snakemake records the params of every job, so a job reruns when the part of
    the configuration its task reads changes, and only then.
    """

    def config_of_job(wildcards):
        sliced = {name: config[name] for name in sections if name in config}
        for name, keys in parts.items():
            wanted = keys(wildcards) if callable(keys) else keys
            sliced[name] = {key: config[name][key] for key in wanted if key in config.get(name, {})}
        return sliced

    return config_of_job


# --------------------------------------------------------------------------- the structure


# The paper's oscillator (two_dof), a finite-element beam or matrices from files (config `structure`): the
# default target is the paper's figures for the first, the structure's own figures for the others.
STRUCTURE_KIND = config.get("structure", {}).get("kind", "two_dof")


def structure_files(wildcards=None):
    """The matrix files of a structure of one's own, as inputs of the rules that build it (an edit reruns them)."""
    if STRUCTURE_KIND != "matrices":
        return {}
    spec = config["structure"]["matrices"]
    return {"mass": spec["mass"], "stiffness": spec["stiffness"]}


# --------------------------------------------------------------------------- regularized branches


def stage_file(branch, stage):
    """The dataset of one continuation stage of a regularized branch (rule hbm_stage)."""
    return expand(rules.hbm_stage.output.dataset, branch=branch, stage=stage)[0]


def stage_files(branch):
    """The stage datasets of a branch, in order."""
    return [stage_file(branch, k) for k in range(1, len(config["branches"][branch]["stages"]) + 1)]


def branch_file(branch):
    """The whole regularized branch (rule hbm_branch)."""
    return expand(rules.hbm_branch.output.dataset, branch=branch)[0]


def bifurcated_file(name):
    """The branch switched at the branch point `bifurcations.<name>` (rule hbm_bifurcated)."""
    return expand(rules.hbm_bifurcated.output.dataset, bifurcation=name)[0]


def previous_stage(wildcards):
    """Stage k > 1 of a branch starts from the dataset of stage k - 1; the structure's files, if any."""
    stage = int(wildcards.stage)
    previous = {"previous": stage_file(wildcards.branch, stage - 1)} if stage > 1 else {}
    return {**previous, **structure_files()}


def branch_stages(wildcards):
    """All stage datasets of a branch, in order."""
    return {"stages": stage_files(wildcards.branch)}


def bifurcation_parent(wildcards):
    """The whole parent branch, on which the branch point of the resonance is looked for; the structure's files."""
    spec = config["bifurcations"][wildcards.bifurcation]
    return {"parent": branch_file(spec["parent"]), **structure_files()}


# --------------------------------------------------------------------------- figures


def figure_stages(figure):
    """NNM1 stage datasets read by paper figure `figure`: stages 1 to the last of `figures.<figure>.nnm1_stages`
    (each stage is built from the one before, so this builds nothing more); the figure draws its own stages,
    or its scene by physics where they hold no orbit (nnmstop.figures.frequency_energy.scene_part)."""
    stages = config["figures"].get(figure, {}).get("nnm1_stages")
    if not stages:
        raise ValueError(f"the configuration has no 'figures.{figure}.nnm1_stages'")
    available = len(config["branches"]["nnm1"]["stages"])
    unknown = [k for k in stages if not 1 <= k <= available]
    if unknown:
        raise ValueError(
            f"figures.{figure}.nnm1_stages: stage(s) {unknown} do not exist (branches.nnm1 has {available} stages)"
        )
    return [stage_file("nnm1", k) for k in range(1, max(stages) + 1)]


def bifurcated_files(figure):
    """Switched-branch datasets drawn on a figure (`figures.<figure>.bifurcated`)."""
    return [bifurcated_file(name) for name in config["figures"][figure].get("bifurcated", [])]


def exact_overlay(wildcards):
    """The exact multi-impact NNM1, for Figs 7-11 when figures.overlay_exact is true."""
    if config.get("figures", {}).get("overlay_exact", False):
        return {"exact": rules.exact_nnm1.output.dataset}
    return {}


def paper_datasets():
    """Every dataset behind the figures of the default target (the study's measurements are kept apart)."""
    datasets = [
        branch_file("nnm1"),
        branch_file("nnm2"),
        *stage_files("nnm1"),
        *stage_files("nnm2"),
        *[bifurcated_file(name) for name in config.get("bifurcations", {})],
    ]
    if STRUCTURE_KIND != "two_dof":
        return datasets + [STRUCTURE_DATASETS["exact"], STRUCTURE_DATASETS["comparison"]]
    datasets += [rules.exact_two_impacts.output.dataset, rules.compare_nnm1.output.dataset]
    # The error per impact regime needs the exact multi-impact NNM1, whose settings section
    # (exact_multi) a configuration may leave out: then there is no such branch to compare.
    if "exact_multi" in config:
        datasets += [rules.exact_nnm1.output.dataset, rules.compare_regimes.output.dataset]
    return datasets


def paper_figure_files():
    """The figures of the default target, PDF and PNG of each: the paper's Figs 2-11 for its oscillator; for
    another structure the frequency-energy figures configured under `figures` and the structure's own."""
    if STRUCTURE_KIND == "two_dof":
        return [path for n in range(2, 12) for path in getattr(rules, f"paper_fig{n:02d}").output]
    configured = [n for n in range(5, 12) if f"fig{n:02d}" in config.get("figures", {})]
    paper = [path for n in configured for path in getattr(rules, f"paper_fig{n:02d}").output]
    own = expand(rules.structure_figure.output, figure=structure_figure_inputs())
    return paper + own


# --------------------------------------------------------------------------- study


def study_case_files():
    """Files of the error-against-run-time jobs, by kind, in the order the gather expects."""
    cases, n = sweep_cases(study_settings(config)), format_number
    return {
        "cases": [results(f"study/cases/H{H}_eta{n(eta)}.nc") for H, eta in cases["cases"]],
        "anm_cases": [results(f"study/cases/anm_N{order}_tol{n(tol)}.nc") for order, tol in cases["anm_cases"]],
        "references": [results(f"study/cases/reference_eta{n(eta)}.nc") for eta in cases["references"]],
        "exact_cost": results("study/cases/exact_cost.nc"),
    }


def stiff_case_files():
    """Files of the stiff-case jobs, by kind, in the order the gather expects."""
    cases, n = stiff_case_parameters(study_settings(config)), format_number
    return {
        "exact": [results(f"study/stiff/exact_a{n(a)}_b{n(b)}_d{n(d)}.nc") for a, b, d in cases["exact"]],
        "branches": [results(f"study/stiff/nnm1_a{n(a)}_b{n(b)}_d{n(d)}_e{n(e)}.nc") for a, b, d, e in cases["branches"]],
        "energy": [results(f"study/stiff/energy_a{n(a)}.nc") for a in cases["energy"]],
    }


# --------------------------------------------------------------------------- finite-element tube


# Datasets each tube figure draws (the keys are the figure task's named inputs).
TUBE_FIGURE_INPUTS = {
    "frequency_energy": ["nnm1", "nnm2", "exact"],
    "shapes": ["nnm1"],
    "contact_force": ["nnm1"],
    "exact_vs_regularized": ["nnm1", "exact", "comparison"],
}


def structure_figure_inputs():
    """Datasets each structure figure of the default target draws (deformed shapes for beams only)."""
    return {name: keys for name, keys in TUBE_FIGURE_INPUTS.items() if name != "shapes" or STRUCTURE_KIND == "beam"}


def tube_file(name):
    """A dataset of the tube under results/tube/."""
    return results(f"tube/{name}.nc")


TUBE_DATASETS = {"nnm1": tube_file("nnm1"), "nnm2": tube_file("nnm2"), "exact": tube_file("exact_nnm1"),
                 "comparison": tube_file("nnm1_exact_vs_regularized")}


def tube_study_files():
    """One dataset per (gap, stop stiffness factor) of `tube.study`."""
    study = config["tube"]["study"]
    return [tube_file(f"study/gap{g:g}_k{k:g}") for g in study["gaps"] for k in study["stiffness_factors"]]


def tube_manifest_datasets():
    """Every dataset of the tube target: branches and their stages, exact family, comparison, study cases (and the
    tube in a circular hole's branches and stages when `tube.circular_hole` is configured)."""
    stages = [path for branch in config["tube"]["branches"] for path in tube_stage_files(branch)]
    circular = [path for branch in circular_hole_branches() for path in tube_circular_stage_files(branch)]
    circular += list(tube_circular_datasets().values())
    return sorted(set(TUBE_DATASETS.values()) | set(stages) | set(tube_study_files()) | set(circular))


# The tube in a circular hole at its plates (`tube.circular_hole`, rules tube_circular_*): figures and the datasets
# they draw (every branch of the scene).
TUBE_CIRCULAR_FIGURES = ("wear",)


def circular_hole_branches():
    """The branches of the tube in a circular hole: none when `tube.circular_hole` is not configured."""
    return config["tube"].get("circular_hole", {}).get("branches", {})


def tube_circular_datasets():
    """The branch datasets of the tube in a circular hole, by branch name."""
    return {branch: results(f"tube/circular/{branch}.nc") for branch in circular_hole_branches()}


def tube_circular_stage_files(branch):
    """The stage datasets of a branch of the tube in a circular hole, in order (rule tube_circular_stage)."""
    count = len(circular_hole_branches()[branch]["stages"])
    return [results(f"tube/circular/stages/{branch}_stage{k}.nc") for k in range(1, count + 1)]


def tube_circular_previous_stage(wildcards):
    """Stage k > 1 of a branch of the tube in a circular hole starts from the dataset of stage k - 1."""
    stage = int(wildcards.stage)
    return {"previous": tube_circular_stage_files(wildcards.branch)[stage - 2]} if stage > 1 else {}


def tube_circular_outputs():
    """What the tube target builds of the tube in a circular hole: its branches and figures (nothing when
    `tube.circular_hole` is not configured)."""
    if not circular_hole_branches():
        return []
    figures = expand(paper_figures("tube_circular_{figure}.{ext}"), figure=TUBE_CIRCULAR_FIGURES, ext=("pdf", "png"))
    return list(tube_circular_datasets().values()) + figures


def tube_circular_task_config(*sections, branches=False):
    """`params: config=...` of a tube_circular rule: `sections` of nnmstop.tasks.tube.circular_hole_config, and with
    `branches` only the rule's own branch."""

    def config_of_job(wildcards):
        shaped = circular_hole_config(config)
        sliced = {name: shaped[name] for name in sections}
        if branches:
            sliced["branches"] = {wildcards.branch: shaped["branches"][wildcards.branch]}
        return sliced

    return config_of_job


def tube_stage_files(branch):
    """The stage datasets of a tube branch, in order (rule tube_stage)."""
    count = len(config["tube"]["branches"][branch]["stages"])
    return [results(f"tube/stages/{branch}_stage{k}.nc") for k in range(1, count + 1)]


def tube_previous_stage(wildcards):
    """Stage k > 1 of a tube branch starts from the dataset of stage k - 1."""
    stage = int(wildcards.stage)
    return {"previous": tube_stage_files(wildcards.branch)[stage - 2]} if stage > 1 else {}


def tube_task_config(*sections, branches=False):
    """`params: config=...` of a tube rule: the `tube` section in the shape of the top-level configuration
    (nnmstop.tasks.tube.tube_config), only `sections` of it, and with `branches` only the rule's own branch."""

    def config_of_job(wildcards):
        shaped = tube_config(config)
        sliced = {name: shaped[name] for name in sections}
        if branches:
            sliced["branches"] = {wildcards.branch: shaped["branches"][wildcards.branch]}
        return sliced

    return config_of_job


# --------------------------------------------------------------------------- tube on several support plates
# Files and task configurations of workflow/rules/tube_plates.smk (the `tube_plates` section, issue 32).

PLATES_FIGURES = ("frequency_energy", "shapes", "contact_force")


def plates_file(name):
    """A dataset of the tube on plates under results/tube_plates/."""
    return results(f"tube_plates/{name}.nc")


def plates_stage_files(branch):
    """The stage datasets of a branch of the tube on plates, in order (rule tube_plates_stage)."""
    count = len(config["tube_plates"]["branches"][branch]["stages"])
    return [results(f"tube_plates/stages/{branch}_stage{k}.nc") for k in range(1, count + 1)]


def plates_previous_stage(wildcards):
    """Stage k > 1 of a branch of the tube on plates starts from the dataset of stage k - 1."""
    stage = int(wildcards.stage)
    return {"previous": plates_stage_files(wildcards.branch)[stage - 2]} if stage > 1 else {}


def plates_task_config(*sections, branches=False):
    """`params: config=...` of a tube_plates rule: `sections` of nnmstop.tasks.tube.plates_config."""

    def config_of_job(wildcards):
        shaped = plates_config(config)
        sliced = {name: shaped[name] for name in sections}
        if branches:
            sliced["branches"] = {wildcards.branch: shaped["branches"][wildcards.branch]}
        return sliced

    return config_of_job


def plates_manifest_datasets():
    """Every dataset of the tube on plates: its branches and their stages, the forced response (and the tube on plates
    in circular holes' branches and stages when `tube_plates.circular_hole` is configured)."""
    branches = config["tube_plates"]["branches"]
    stages = [path for branch in branches for path in plates_stage_files(branch)]
    circular = [path for branch in plates_circular_branches() for path in plates_circular_stage_files(branch)]
    circular += list(plates_circular_datasets().values())
    return [plates_file(name) for name in branches] + stages + [plates_forced_file()] + circular


# The tube on plates in a circular hole at each plate (`tube_plates.circular_hole`, rules tube_plates_circular_*):
# figures of every branch of the scene.
PLATES_CIRCULAR_FIGURES = ("wear", "hole_shapes", "hole_contact")


def plates_circular_branches():
    """The branches of the tube on plates in circular holes: none when `tube_plates.circular_hole` is not configured."""
    return config["tube_plates"].get("circular_hole", {}).get("branches", {})


def plates_circular_datasets():
    """The branch datasets of the tube on plates in circular holes, by branch name."""
    return {branch: plates_file(f"circular/{branch}") for branch in plates_circular_branches()}


def plates_circular_stage_files(branch):
    """The stage datasets of a branch of the tube on plates in circular holes, in order."""
    count = len(plates_circular_branches()[branch]["stages"])
    return [plates_file(f"circular/stages/{branch}_stage{k}") for k in range(1, count + 1)]


def plates_circular_previous_stage(wildcards):
    """Stage k > 1 of a branch of the tube on plates in circular holes starts from the dataset of stage k - 1."""
    stage = int(wildcards.stage)
    return {"previous": plates_circular_stage_files(wildcards.branch)[stage - 2]} if stage > 1 else {}


def plates_circular_outputs():
    """What the tube_plates target builds of the circular holes: branches and figures (none when not configured)."""
    if not plates_circular_branches():
        return []
    figures = expand(paper_figures("tube_plates_circular_{figure}.{ext}"), figure=PLATES_CIRCULAR_FIGURES, ext=("pdf", "png"))
    return list(plates_circular_datasets().values()) + figures


def plates_circular_task_config(*sections, branches=False):
    """`params: config=...` of a tube_plates_circular rule: `sections` of
    nnmstop.tasks.tube_plates.plates_circular_config, and with `branches` only the rule's own branch."""

    def config_of_job(wildcards):
        shaped = plates_circular_config(config)
        sliced = {name: shaped[name] for name in sections}
        if branches:
            sliced["branches"] = {wildcards.branch: shaped["branches"][wildcards.branch]}
        return sliced

    return config_of_job


def plates_forced_file():
    """The forced response of the tube on plates at `tube_plates.forced.amplitude`."""
    amplitude = config["tube_plates"]["forced"]["amplitude"]
    return plates_file(f"forced_F{float(amplitude):g}".replace("e+", "e"))


# --------------------------------------------------------------------------- explorer


def explorer_branches():
    """Datasets drawn by the explorer, by kind of branch (nnmstop.explorer.extract.KINDS): for another structure
    than the paper's oscillator its exact one-stop family (kind exact_one_stop, orbits rebuilt on the structure)."""
    regularized = [branch_file("nnm1"), branch_file("nnm2"), *[bifurcated_file(name) for name in config.get("bifurcations", {})]]
    if config.get("explorer", {}).get("tube", False) and "tube" in config:  # the tube's branches, built for it
        regularized += [tube_file(name) for name in config["tube"]["branches"]]
    if STRUCTURE_KIND != "two_dof":
        inputs = {"regularized": regularized, "exact_one_stop": [STRUCTURE_DATASETS["exact"]]}
    else:
        exact = rules.exact_nnm1.output.dataset if "exact_multi" in config else rules.exact_two_impacts.output.dataset
        inputs = {"regularized": regularized, "exact": [exact]}
    if config.get("explorer", {}).get("atlas", False) and "atlas" in config:  # the atlas' maps, built for it
        names = list(config["atlas"]["maps"])
        inputs["atlas"] = [results(f"atlas/{name}.nc") for name in names]
        inputs["atlas_slices"] = [path for name in names for path in atlas_slice_files(name)]
    return inputs


# --------------------------------------------------------------------------- forced
# Forced responses (workflow/rules/forced.smk): the scenes of the configuration and their files.


def forced_scene_names(which="all", exact=False):
    """File stems of the forced responses of the configuration (`F0.05`, ..., `tube_F0.5`); with `exact`, only those
    whose exact response is computed (nnmstop.forced.scenes.exact_response_gap: one stop)."""
    from nnmstop.forced.scenes import exact_response_gap, forced_scenes

    if "forced" not in config:
        return []
    return [scene.name for scene in forced_scenes(config, which) if not (exact and exact_response_gap(scene))]


def forced_file(kind, scene):
    """The dataset of one forced response: kind `exact` or `regularized`."""
    return results(f"forced/{kind}_{scene}.nc")


def forced_datasets():
    """Every dataset of the forced target."""
    names = forced_scene_names()
    own = forced_scene_names("structure", exact=True)
    return (
        [forced_file("exact", s) for s in own]
        + [forced_file("regularized", s) for s in names]
        + [rules.forced_backbone.output.dataset, rules.forced_prediction.output.dataset]
    )


def forced_figures():
    """The forced figures of the configuration (the tube's only when it is configured)."""
    figures = [f for f in FORCED_FIGURE_INPUTS if f != "tube" or forced_scene_names("tube")]
    return expand(paper_figures("forced_{figure}.{ext}"), figure=figures, ext=("pdf", "png"))


# --------------------------------------------------------------------------- atlas
# The bifurcation atlas (workflow/rules/atlas.smk): its maps, slices and curves (nnmstop.bifurcation_atlas.maps).


def ATLAS_CONFIG(wildcards):
    """The configuration an atlas job reads: its own map of `atlas.maps` (with the section's shared keys), and the
    sections the maps take their structure, damping and numerics from. Editing one map reruns only its jobs."""
    sliced = task_config("model", "structure", "anm", "forced", "metadata", tube=["structure"])(wildcards)
    atlas = {key: value for key, value in config["atlas"].items() if key != "maps"}
    names = [wildcards.map] if "map" in wildcards.keys() else list(config["atlas"]["maps"])
    atlas["maps"] = {name: config["atlas"]["maps"][name] for name in names}
    return {**sliced, "atlas": atlas}


def atlas_map_names():
    """The maps of the `atlas` section (none without it)."""
    from nnmstop.bifurcation_atlas.maps import map_names

    return map_names(config)


def atlas_slice_files(name):
    """The slice datasets of a map, in order."""
    from nnmstop.bifurcation_atlas.maps import slice_values

    count = len(slice_values(config["atlas"]["maps"][name]))
    return [results(f"atlas/{name}/slice_{k}.nc") for k in range(count)]


def atlas_curve_files(name):
    """The curve datasets of a map, one per kind."""
    return [results(f"atlas/{name}/curves_{kind}.nc") for kind in config["atlas"]["maps"][name]["kinds"]]


def _atlas_slices_at(name, values):
    from nnmstop.bifurcation_atlas.maps import slice_values

    slices = slice_values(config["atlas"]["maps"][name])
    files = atlas_slice_files(name)
    return [files[min(range(len(slices)), key=lambda k: abs(slices[k] - float(v)))] for v in values]


def atlas_curve_inputs(wildcards):
    """The seed and check slices of a curve job (none for the regularized kinds, computed in the job)."""
    spec = config["atlas"]["maps"][wildcards.map]
    if wildcards.kind.startswith("regularized_"):
        return {}
    return {"seeds": _atlas_slices_at(wildcards.map, spec["seeds"]), "checks": _atlas_slices_at(wildcards.map, spec["checks"])}


def atlas_has_backbone(name):
    """Whether a map draws the backbones' prediction (a `backbone` section, force or gap plane)."""
    spec = config["atlas"]["maps"][name]
    return "backbone" in spec and spec["plane"] in ("force", "gap")


def atlas_figure_inputs(wildcards):
    """The atlas dataset of a map and, where it draws them, its backbones."""
    inputs = {"atlas": results(f"atlas/{wildcards.map}.nc")}
    if atlas_has_backbone(wildcards.map):
        inputs["backbone"] = results(f"atlas/{wildcards.map}_backbone.nc")
    return inputs


def atlas_figure_pngs():
    """The PNG of every map's figure (the docs page shows them)."""
    return expand(paper_figures("atlas_{map}.png"), map=atlas_map_names())


def atlas_datasets():
    """The atlas dataset of every map and its backbones."""
    names = atlas_map_names()
    return [results(f"atlas/{name}.nc") for name in names] + [
        results(f"atlas/{name}_backbone.nc") for name in names if atlas_has_backbone(name)
    ]


def verified_inputs(wildcards):
    """What verify checks and update_reference record (workflow/rules/verify.smk): the paper's datasets and
    their manifest and, where the configuration has them, the forced, tube, study, tube-on-plates and atlas datasets
    (their manifests)."""
    inputs = dict(datasets=PAPER_DATASETS, manifest=rules.dataset_manifest.output.manifest)
    if "forced" in config:
        inputs.update(forced_datasets=forced_datasets(), forced_manifest=rules.forced_manifest.output.manifest)
    if "tube" in config:
        inputs.update(tube_manifest=rules.tube_manifest.output.manifest)
    if "study" in config:
        inputs.update(study_manifest=rules.study_manifest.output.manifest)
    if "tube_plates" in config:
        inputs.update(tube_plates_manifest=rules.tube_plates_manifest.output.manifest)
    if "atlas" in config:
        inputs.update(atlas_datasets=atlas_datasets(), atlas_manifest=rules.atlas_manifest.output.manifest)
    return inputs


# --------------------------------------------------------------------------- docs and report


def docs_inputs(wildcards):
    """The datasets of the pages: the paper's oscillator's (the switched branches only where `bifurcations` has
    them; the small test configuration has none), or a structure of one's own's; and the front-page figure."""
    if STRUCTURE_KIND != "two_dof":
        return {
            **{name: results(path) for name, path in STRUCTURE_PAGE_DATASETS.items()},
            "figure": paper_figures("structure_frequency_energy.png"),
        }
    inputs = {
        name: results(path)
        for name, path in {**RESULT_DATASETS, **PAPER_TABLE_DATASETS}.items()
        if name not in OPTIONAL_DATASETS or name in config.get("bifurcations", {})
    }
    return {**inputs, "figure": rules.paper_fig02.output.png}



def built_figures():
    """The figures of the default target and every other figure of the configuration that the build made (exists
    now): the extra figures, the forced, tube (and tube in a circular hole), study, tube-on-plates and atlas ones. `snakemake --report report.html report_figures`
    puts them all in the report; a figure not built is left out rather than built for the report."""
    candidates = [*rules.regime_error_figure.output, *rules.stability_figure.output]
    candidates += [*rules.study_error_vs_runtime_figure.output, *rules.study_stiff_cases_figure.output]
    if "forced" in config:
        candidates += forced_figures()
    if "tube" in config:
        candidates += expand(paper_figures("tube_{figure}.{ext}"), figure=TUBE_FIGURE_INPUTS, ext=("pdf", "png"))
        candidates += list(rules.tube_study.output)
        candidates += [path for path in tube_circular_outputs() if path.startswith(paper_figures(""))]
    if "tube_plates" in config:
        candidates += expand(paper_figures("tube_plates_{figure}.{ext}"), figure=PLATES_FIGURES + ("forced",),
                             ext=("pdf", "png"))
        candidates += [path for path in plates_circular_outputs() if path.startswith(paper_figures(""))]
    if "atlas" in config:
        candidates += expand(paper_figures("atlas_{map}.{ext}"), map=atlas_map_names(), ext=("pdf", "png"))
    return PAPER_FIGURES + [path for path in candidates if path not in PAPER_FIGURES and os.path.exists(path)]

