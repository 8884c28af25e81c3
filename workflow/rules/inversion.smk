# inversion_outputs() (targets of rule all) lives in common.smk: the linter wants functions apart from rules.


rule invert:
    """Dropper-only inversion of the corrected spans (paper §4.1): Table 1 and Fig. 8 analogues."""
    input:
        corrected=f"{RESULTS}/{{span_type}}/corrected.parquet",
        catenary=config["catenary"],
    output:
        droppers=f"{RESULTS}/{{span_type}}/inversion/droppers.parquet",
        **table("table1", f"{RESULTS}/{{span_type}}/inversion/table1.csv", "table1", INVERSION, "Table 1"),
        pearson=reported(f"{RESULTS}/{{span_type}}/inversion/pearson.png", "pearson", INVERSION, "Fig. 8: correlations"),
    params:
        inversion=config["inversion"],
    # The spans in `threads` worker processes (the same inversion for any number; the default
    # profile gives each of the two span types' jobs one, side by side).
    threads: 2
    log:
        f"{RESULTS}/logs/invert/{{span_type}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/invert/{{span_type}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/invert.py"


rule tension_impact:
    """Paper Fig. 6: measured sags of two catenaries with the same static sag at two T_MW."""
    input:
        catenary=config["catenary"],
        pantographs=config["pantographs"],
    output:
        **table("summary", f"{RESULTS}/{{span_type}}/tension_impact/summary.csv", "tension_impact_summary", PAPER, "Fig. 6: summary"),
        figure=reported(f"{RESULTS}/{{span_type}}/tension_impact/tension_impact.png", "tension_impact", PAPER, "Fig. 6: T_MW impact"),
    params:
        tension_impact=config["tension_impact"],
    log:
        f"{RESULTS}/logs/tension_impact/{{span_type}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/tension_impact/{{span_type}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/tension_impact.py"
