rule dropper_table:
    """Nominal dropper table of a span type from its presag profile."""
    input:
        catenary=config["catenary"],
    output:
        **table("table", f"{RESULTS}/{{span_type}}/nominal/dropper_table.csv", "dropper_table", PAPER, "Nominal dropper table"),
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
        **table("summary", f"{RESULTS}/{{span_type}}/sensitivity/summary.csv", "sensitivity_summary", PAPER, "Figs 2–4: summary"),
        fig2=reported(f"{RESULTS}/{{span_type}}/sensitivity/fig2_tensions.png", "fig2_tensions", PAPER, "Fig. 2: tensions"),
        fig3=reported(f"{RESULTS}/{{span_type}}/sensitivity/fig3_steady_arms.png", "fig3_steady_arms", PAPER, "Fig. 3: steady arms"),
        fig4=reported(f"{RESULTS}/{{span_type}}/sensitivity/fig4_system_height.png", "fig4_system_height", PAPER, "Fig. 4: system height"),
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
