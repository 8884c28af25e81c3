rule dynamics:
    """High-speed runs over a section of the span type; EN 50318-style statistics."""
    input:
        catenary=config["catenary"],
        pantographs=config["pantographs"],
    output:
        **table("statistics", f"{RESULTS}/{{span_type}}/dynamics/statistics.csv", "dynamics_statistics", PAPER, "EN 50318 statistics"),
        figure=reported(f"{RESULTS}/{{span_type}}/dynamics/contact_force.png", "dynamics_figure", PAPER, "Contact force at speed"),
    params:
        dynamics=config["dynamics"],
    log:
        f"{RESULTS}/logs/dynamics/{{span_type}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/dynamics/{{span_type}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/dynamics.py"
