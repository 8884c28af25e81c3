# contact_force_outputs() and contact_force_batches() live in common.smk.


rule contact_force_batch:
    """Dynamic runs over one batch of random sections drawn from the identified laws (or a
    tolerance case's): EN 50318 criteria and EN 50367 limits per replicate and speed."""
    input:
        s_opt=later_laws,
        findings=f"{RESULTS}/{{span_type}}/diagnosis/findings.csv",
        catenary=config["catenary"],
        pantographs=config["pantographs"],
    output:
        batch=f"{RESULTS}/{{span_type}}/contact_force/batches/{{case}}_{{batch}}.parquet",
    wildcard_constraints:
        case="identified|sobol|tolerance",
        batch="[0-9]+",
    params:
        contact_force=span_type_settings("contact_force"),
    log:
        f"{RESULTS}/logs/contact_force_batch/{{span_type}}_{{case}}_{{batch}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/contact_force_batch/{{span_type}}_{{case}}_{{batch}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/contact_force_batch.py"


rule contact_force:
    """Gather: statistics of the criteria over random sections, the nominal section's, violation
    probabilities, the tolerance study, the sensitivity and the report."""
    input:
        batches=lambda wc: contact_force_batches(wc.span_type),
        s_opt=later_laws,
        findings=f"{RESULTS}/{{span_type}}/diagnosis/findings.csv",
        catenary=config["catenary"],
        pantographs=config["pantographs"],
    output:
        replicates=f"{RESULTS}/{{span_type}}/contact_force/replicates.parquet",
        **table("summary", f"{RESULTS}/{{span_type}}/contact_force/summary.csv", "cf_summary", CONTACT_FORCE, "Criteria over random sections"),
        **table("nominal", f"{RESULTS}/{{span_type}}/contact_force/nominal.csv", "cf_nominal", CONTACT_FORCE, "Nominal section"),
        **table("tolerance", f"{RESULTS}/{{span_type}}/contact_force/tolerance.csv", "cf_tolerance", CONTACT_FORCE, "Tolerance study"),
        **table("sensitivity", f"{RESULTS}/{{span_type}}/contact_force/sensitivity.csv", "cf_sensitivity", CONTACT_FORCE, "Sobol indices"),
        histograms=reported(f"{RESULTS}/{{span_type}}/contact_force/histograms.png", "cf_histograms", CONTACT_FORCE, "Histograms"),
        sobol=reported(f"{RESULTS}/{{span_type}}/contact_force/sobol.png", "cf_sobol", CONTACT_FORCE, "Sobol bar chart"),
        tolerance_figure=reported(f"{RESULTS}/{{span_type}}/contact_force/tolerance.png", "cf_tolerance_figure", CONTACT_FORCE, "Tolerance curve"),
        report=f"{RESULTS}/{{span_type}}/contact_force/report.md",
    params:
        contact_force=span_type_settings("contact_force"),
        folder=lambda wc: f"{RESULTS}/{wc.span_type}/contact_force",
    log:
        f"{RESULTS}/logs/contact_force/{{span_type}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/contact_force/{{span_type}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/contact_force.py"
