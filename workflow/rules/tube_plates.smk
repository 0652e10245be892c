# Issue 32: a tube on several support plates (the `tube_plates` section), reduced onto the plates' DOFs
# (Craig-Bampton, nnmstop.models.reduction): the HBM and structure tasks of any structure on the reduced
# structure (NNM1 with its stability, figures of the deformed tube and of each plate's contact force), and its
# forced response; with `tube_plates.circular_hole` the same tube bending in two planes in a circular hole at each
# plate (planar and whirling branches, results/tube_plates/circular/). `snakemake --cores 2 tube_plates` builds all
# of it. Tasks: nnmstop.tasks.tube_plates;
# helpers (plates_file, plates_task_config, ...): workflow/rules/common.smk.

rule tube_plates_stage:
    """One continuation stage of a regularized NNM of the reduced tube on plates."""
    input:
        unpack(plates_previous_stage),
    output:
        dataset=results("tube_plates/stages/{branch}_stage{stage}.nc"),
    wildcard_constraints:
        branch="nnm[0-9]+",
        stage=r"\d+",
    log:
        logs("tube_plates/{branch}_stage{stage}.log"),
    benchmark:
        benchmarks("tube_plates_{branch}_stage{stage}.tsv")
    params:
        config=plates_task_config("structure", "hbm", "anm", "stability", "metadata", branches=True),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_plates_branch:
    """A regularized NNM of the reduced tube on plates: its stages joined."""
    input:
        stages=lambda wildcards: plates_stage_files(wildcards.branch),
    output:
        dataset=results("tube_plates/{branch}.nc"),
    wildcard_constraints:
        branch="nnm[0-9]+",
    log:
        logs("tube_plates/{branch}.log"),
    benchmark:
        benchmarks("tube_plates_{branch}.tsv")
    params:
        config=plates_task_config("metadata"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_plates_figure:
    """paper_figures/tube_plates_<figure>.{pdf,png}: NNM1's frequency-energy plot, deformed shapes on the full
    mesh and the contact force of each plate."""
    input:
        nnm1=plates_file("nnm1"),
    output:
        pdf=paper_figures("tube_plates_{figure}.pdf"),
        png=report(paper_figures("tube_plates_{figure}.png"), category="Tube on plates", subcategory="{figure}"),
    wildcard_constraints:
        figure="|".join(PLATES_FIGURES),
    log:
        logs("tube_plates/figure_{figure}.log"),
    benchmark:
        benchmarks("tube_plates_figure_{figure}.tsv")
    params:
        config=plates_task_config("figures"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_plates_forced:
    """The forced response of the reduced tube on plates (`tube_plates.forced`)."""
    output:
        dataset=plates_forced_file(),
    log:
        logs("tube_plates/forced.log"),
    benchmark:
        benchmarks("tube_plates_forced.tsv")
    params:
        config=plates_task_config("structure", "anm", "forced", "metadata"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_plates_forced_figure:
    """paper_figures/tube_plates_forced.{pdf,png}: max |q| at the middle plate and the forced DOF."""
    input:
        dataset=rules.tube_plates_forced.output.dataset,
    output:
        pdf=paper_figures("tube_plates_forced.pdf"),
        png=report(paper_figures("tube_plates_forced.png"), category="Tube on plates"),
    log:
        logs("tube_plates/figure_forced.log"),
    benchmark:
        benchmarks("tube_plates_forced_figure.tsv")
    params:
        config=plates_task_config("figures"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_plates_circular_stage:
    """One continuation stage of a branch of the reduced tube on plates in circular holes
    (`tube_plates.circular_hole.branches`: planar or whirling)."""
    input:
        unpack(plates_circular_previous_stage),
    output:
        dataset=results("tube_plates/circular/stages/{branch}_stage{stage}.nc"),
    wildcard_constraints:
        branch="(nnm|whirl)[0-9]+",
        stage=r"\d+",
    log:
        logs("tube_plates/circular_{branch}_stage{stage}.log"),
    benchmark:
        benchmarks("tube_plates_circular_{branch}_stage{stage}.tsv")
    params:
        config=plates_circular_task_config("structure", "hbm", "anm", "stability", "metadata", branches=True),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_plates_circular_branch:
    """A branch of the reduced tube on plates in circular holes: its stages joined."""
    input:
        stages=lambda wildcards: plates_circular_stage_files(wildcards.branch),
    output:
        dataset=results("tube_plates/circular/{branch}.nc"),
    wildcard_constraints:
        branch="(nnm|whirl)[0-9]+",
    log:
        logs("tube_plates/circular_{branch}.log"),
    benchmark:
        benchmarks("tube_plates_circular_{branch}.tsv")
    params:
        config=plates_circular_task_config("metadata"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_plates_circular_figure:
    """paper_figures/tube_plates_circular_<figure>.{pdf,png}: the branches in circular holes, their wear power per
    plate, the deformed tube in both planes, each plate's orbit in its hole and radial contact force."""
    input:
        unpack(lambda wildcards: plates_circular_datasets()),
    output:
        pdf=paper_figures("tube_plates_circular_{figure}.pdf"),
        png=report(paper_figures("tube_plates_circular_{figure}.png"), category="Tube on plates", subcategory="circular holes"),
    wildcard_constraints:
        figure="|".join(PLATES_CIRCULAR_FIGURES),
    log:
        logs("tube_plates/circular_figure_{figure}.log"),
    benchmark:
        benchmarks("tube_plates_circular_figure_{figure}.tsv")
    params:
        config=plates_circular_task_config("figures"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_plates_manifest:
    """results/tube_plates/MANIFEST.sha256 over the tube on plates' branches, stages and forced response, and its
    branches in circular holes when configured (recorded by update_reference, checked by verify)."""
    input:
        datasets=plates_manifest_datasets(),
    output:
        manifest=results("tube_plates/MANIFEST.sha256"),
    log:
        logs("tube_plates/manifest.log"),
    benchmark:
        benchmarks("tube_plates_manifest.tsv")
    params:
        config=task_config(),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_plates:
    """Everything of the tube on plates: NNM1 (stability included), its figures, the forced response, the branches in
    circular holes (`tube_plates.circular_hole`) with their figures, and the manifest."""
    input:
        rules.tube_plates_manifest.output.manifest,
        [plates_file(name) for name in config["tube_plates"]["branches"]],
        expand(paper_figures("tube_plates_{figure}.{ext}"), figure=PLATES_FIGURES, ext=("pdf", "png")),
        rules.tube_plates_forced_figure.output,
        plates_circular_outputs(),
