# The bifurcation atlas (issue 31): maps of a forced structure over the frequency and the force (or a structural
# parameter). Each slice (one exact response) and each kind of curve is its own job, so that a cluster spreads a
# large atlas (`snakemake --profile profiles/slurm atlas`). `snakemake --cores 2 atlas` builds every map, its
# figure and the manifest. Thin rules: the tasks are in nnmstop.tasks.atlas.

# a map's name as a wildcard: one of the configured maps (so that `<map>_backbone.nc` is never taken for a map)
ATLAS_MAP = "|".join(atlas_map_names()) or "no_map"


rule atlas_slice:
    """One slice of a map: the exact (regularized, for a circular clearance) one-parameter response at one value of
    its second parameter, classified."""
    output:
        dataset=results("atlas/{map}/slice_{index}.nc"),
    wildcard_constraints:
        map=ATLAS_MAP,
        index=r"\d+",
    log:
        logs("atlas/{map}/slice_{index}.log"),
    benchmark:
        benchmarks("atlas_{map}_slice_{index}.tsv")
    params:
        config=ATLAS_CONFIG,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule atlas_curves:
    """The curves of one kind of a map, seeded on its seed slices and checked on its check slices."""
    input:
        unpack(atlas_curve_inputs),
    output:
        dataset=results("atlas/{map}/curves_{kind}.nc"),
    wildcard_constraints:
        map=ATLAS_MAP,
        kind="[a-z_]+",
    log:
        logs("atlas/{map}/curves_{kind}.log"),
    benchmark:
        benchmarks("atlas_{map}_curves_{kind}.tsv")
    params:
        config=ATLAS_CONFIG,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule atlas_map:
    """A map: its slices' regions and its curves in one atlas dataset, with the backbone's prediction of the peak."""
    input:
        slices=lambda wildcards: atlas_slice_files(wildcards.map),
        curves=lambda wildcards: atlas_curve_files(wildcards.map),
    output:
        dataset=results("atlas/{map}.nc"),
    wildcard_constraints:
        map=ATLAS_MAP,
    log:
        logs("atlas/{map}.log"),
    benchmark:
        benchmarks("atlas_{map}.tsv")
    params:
        config=ATLAS_CONFIG,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule atlas_backbone:
    """The NNM backbones of a map's structure and the resonance peaks they predict (layout of forced/backbone.nc)."""
    output:
        dataset=results("atlas/{map}_backbone.nc"),
    wildcard_constraints:
        map=ATLAS_MAP,
    log:
        logs("atlas/{map}_backbone.log"),
    benchmark:
        benchmarks("atlas_{map}_backbone.tsv")
    params:
        config=ATLAS_CONFIG,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule atlas_figure:
    """paper_figures/atlas_<map>.{pdf,png}: the map a designer reads."""
    input:
        unpack(atlas_figure_inputs),
    output:
        pdf=paper_figures("atlas_{map}.pdf"),
        png=report(paper_figures("atlas_{map}.png"), category="Bifurcation atlas"),
    wildcard_constraints:
        map=ATLAS_MAP,
    log:
        logs("atlas/figure_{map}.log"),
    benchmark:
        benchmarks("atlas_figure_{map}.tsv")
    params:
        config=ATLAS_CONFIG,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule atlas_manifest:
    """results/atlas/MANIFEST.sha256 over every atlas dataset (recorded by update_reference, checked by verify)."""
    input:
        datasets=atlas_datasets(),
    output:
        manifest=results("atlas/MANIFEST.sha256"),
    log:
        logs("atlas/manifest.log"),
    benchmark:
        benchmarks("atlas_manifest.tsv")
    params:
        config=ATLAS_CONFIG,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule atlas:
    """Every map of the atlas: datasets, figures and their manifest (not in the default target)."""
    input:
        atlas_datasets(),
        rules.atlas_manifest.output.manifest,
        expand(paper_figures("atlas_{map}.{ext}"), map=atlas_map_names(), ext=("pdf", "png")),


localrules:
    atlas_docs,


rule atlas_docs:
    """docs/atlas_numbers.md from the atlas datasets and the map figures in docs/ (committed; the atlas page)."""
    input:
        atlas=[results(f"atlas/{name}.nc") for name in atlas_map_names()],
        figures=atlas_figure_pngs(),
    output:
        numbers="docs/atlas_numbers.md",
        figures=expand("docs/atlas_{map}.png", map=atlas_map_names()),
    log:
        logs("atlas/docs.log"),
    params:
        config=task_config(),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
