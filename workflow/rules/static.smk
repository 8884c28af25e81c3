rule dropper_table:
    """Nominal dropper table of a span type from its presag profile."""
    input:
        catenary=config["catenary"],
    output:
        table=f"{RESULTS}/{{span_type}}/nominal/dropper_table.csv",
    log:
        f"{RESULTS}/logs/dropper_table/{{span_type}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/dropper_table/{{span_type}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/dropper_table.py"


rule sensitivity:
    """Paper Figs 2–4: W under tension, steady-arm and system-height variations."""
    input:
        catenary=config["catenary"],
    output:
        summary=f"{RESULTS}/{{span_type}}/sensitivity/summary.csv",
        fig2=f"{RESULTS}/{{span_type}}/sensitivity/fig2_tensions.png",
        fig3=f"{RESULTS}/{{span_type}}/sensitivity/fig3_steady_arms.png",
        fig4=f"{RESULTS}/{{span_type}}/sensitivity/fig4_system_height.png",
    params:
        n_points=config["sensitivity"]["n_points"],
    log:
        f"{RESULTS}/logs/sensitivity/{{span_type}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/sensitivity/{{span_type}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/sensitivity.py"
