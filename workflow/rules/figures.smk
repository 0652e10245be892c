# Paper Figs 5-11: frequency-energy plots of the regularized NNMs with modal lines.
# A figure only reads datasets (it never continues a branch), and each rule declares
# only the datasets its figure reads: Fig 6 needs NNM2 alone, Figs 7-11 only the NNM1
# stages listed under `figures.figNN.nnm1_stages` in config/config.yaml.


rule paper_fig05:
    """Fig 5: FEP of NNM1 (blue) and NNM2 (green) over the whole energy range."""
    input:
        nnm1="results/hbm/nnm1.nc",
        nnm2="results/hbm/nnm2.nc",
    output:
        pdf="paper_figures/fig05.pdf",
        png=report("paper_figures/fig05.png", category="Paper figures"),
    log:
        "logs/figures/fig05.log",
    benchmark:
        "benchmarks/runs/paper_fig05.tsv"
    params:
        task="paper_fig05",
        settings=lambda wildcards: repr(config["figures"]["fig05"]),  # rerun when they change
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig06:
    """Fig 6: FEP of NNM2 with modal lines a)-f); reads NNM2 only."""
    input:
        nnm2="results/hbm/nnm2.nc",
    output:
        pdf="paper_figures/fig06.pdf",
        png=report("paper_figures/fig06.png", category="Paper figures"),
    log:
        "logs/figures/fig06.log",
    benchmark:
        "benchmarks/runs/paper_fig06.tsv"
    params:
        task="paper_fig06",
        settings=lambda wildcards: repr(config["figures"]["fig06"]),  # rerun when they change
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig07:
    """Fig 7: NNM1 at low energy, modal lines a)-c)."""
    input:
        unpack(exact_overlay),
        nnm1_stages=lambda wildcards: nnm1_stage_files("fig07"),
    output:
        pdf="paper_figures/fig07.pdf",
        png=report("paper_figures/fig07.png", category="Paper figures"),
    log:
        "logs/figures/fig07.log",
    benchmark:
        "benchmarks/runs/paper_fig07.tsv"
    params:
        task="paper_fig07",
        settings=lambda wildcards: repr(config["figures"]["fig07"]),  # rerun when they change
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig08:
    """Fig 8: NNM1 with the NNM2 curve at f2/3, the 3:1 internal resonance, d)-i)."""
    input:
        unpack(exact_overlay),
        nnm1_stages=lambda wildcards: nnm1_stage_files("fig08"),
        nnm2="results/hbm/nnm2.nc",
        bifurcated=lambda wildcards: bifurcated_files("fig08"),
    output:
        pdf="paper_figures/fig08.pdf",
        png=report("paper_figures/fig08.png", category="Paper figures"),
    log:
        "logs/figures/fig08.log",
    benchmark:
        "benchmarks/runs/paper_fig08.tsv"
    params:
        task="paper_fig08",
        settings=lambda wildcards: repr(config["figures"]["fig08"]),  # rerun when they change
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig09:
    """Fig 9: NNM1 with the NNM2 curve at f2/5, the 5:1 internal resonance, j)-m)."""
    input:
        unpack(exact_overlay),
        nnm1_stages=lambda wildcards: nnm1_stage_files("fig09"),
        nnm2="results/hbm/nnm2.nc",
        bifurcated=lambda wildcards: bifurcated_files("fig09"),
    output:
        pdf="paper_figures/fig09.pdf",
        png=report("paper_figures/fig09.png", category="Paper figures"),
    log:
        "logs/figures/fig09.log",
    benchmark:
        "benchmarks/runs/paper_fig09.tsv"
    params:
        task="paper_fig09",
        settings=lambda wildcards: repr(config["figures"]["fig09"]),  # rerun when they change
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig10:
    """Fig 10: NNM1 with the NNM2 curve at f2/5 after the 5:1 resonance, o)-q)."""
    input:
        unpack(exact_overlay),
        nnm1_stages=lambda wildcards: nnm1_stage_files("fig10"),
        nnm2="results/hbm/nnm2.nc",
        bifurcated=lambda wildcards: bifurcated_files("fig10"),
    output:
        pdf="paper_figures/fig10.pdf",
        png=report("paper_figures/fig10.png", category="Paper figures"),
    log:
        "logs/figures/fig10.log",
    benchmark:
        "benchmarks/runs/paper_fig10.tsv"
    params:
        task="paper_fig10",
        settings=lambda wildcards: repr(config["figures"]["fig10"]),  # rerun when they change
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig11:
    """Fig 11: NNM1 at high energy, tending to the gap-0 first linear mode."""
    input:
        unpack(exact_overlay),
        nnm1_stages=lambda wildcards: nnm1_stage_files("fig11"),
    output:
        pdf="paper_figures/fig11.pdf",
        png=report("paper_figures/fig11.png", category="Paper figures"),
    log:
        "logs/figures/fig11.log",
    benchmark:
        "benchmarks/runs/paper_fig11.tsv"
    params:
        task="paper_fig11",
        settings=lambda wildcards: repr(config["figures"]["fig11"]),  # rerun when they change
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_figs_05_11:
    """All of Figs 5-11 (PDF and PNG)."""
    input:
        expand("paper_figures/fig{number}.{ext}", number=["05", "06", "07", "08", "09", "10", "11"], ext=["pdf", "png"]),
