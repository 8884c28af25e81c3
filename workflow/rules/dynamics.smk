rule dynamics:
    """High-speed runs over a section of the span type; EN 50318-style statistics."""
    input:
        catenary=config["catenary"],
        pantographs=config["pantographs"],
    output:
        statistics=f"{RESULTS}/{{span_type}}/dynamics/statistics.csv",
        figure=f"{RESULTS}/{{span_type}}/dynamics/contact_force.png",
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
