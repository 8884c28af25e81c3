# correction_sections(), correction_batches(), model_error_sections() and correction_outputs() live
# in common.smk: the linter wants functions apart from rules.


rule measuring_response:
    """The measuring pass's response to the static CW per span type and direction of travel, at
    the spans' median speed and force (catenary.stages.correction.step): the step of every
    section's dynamic passes, computed once for the line."""
    input:
        spans=expand(f"{RESULTS}/{{span_type}}/spans.parquet", span_type=SPAN_TYPES),
        catenary=config["catenary"],
        pantographs=config["pantographs"],
    output:
        response=f"{RESULTS}/correction/measuring_response.parquet",
    params:
        correction=config["correction"],
        span_types=SPAN_TYPES,
    # On the chain to the correction, as the projection; its raised supports in worker processes.
    priority: 2
    threads: 2
    log:
        f"{RESULTS}/logs/measuring_response.log",
    benchmark:
        f"{RESULTS}/benchmarks/measuring_response.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/measuring_response.py"


rule correct_section:
    """Iterative dynamic correction of a batch of sections' spans (paper §2.2, Fig. 5): one section
    per job on a line of up to 100 sections (the batch is then named by its section), a long
    line's sections several per job (catenary.stages.correction.batches)."""
    input:
        spans=expand(f"{RESULTS}/{{span_type}}/spans.parquet", span_type=SPAN_TYPES),
        profiles=expand(f"{RESULTS}/{{span_type}}/profiles.parquet", span_type=SPAN_TYPES),
        report=f"{RESULTS}/spans_report.csv",
        response=f"{RESULTS}/correction/measuring_response.parquet",
        catenary=config["catenary"],
        pantographs=config["pantographs"],
    output:
        corrected=f"{RESULTS}/correction/sections/{{batch}}.parquet",
        profiles=f"{RESULTS}/correction/sections/{{batch}}_profiles.parquet",
        convergence=f"{RESULTS}/correction/sections/{{batch}}_convergence.csv",
        model_error=f"{RESULTS}/correction/sections/{{batch}}_model_error.parquet",
    wildcard_constraints:
        batch="[^/]+",
    # A section that also measures the model-error budget takes 3–5 times longer than the others:
    # a batch of its own, started first, it runs beside them instead of alone at the end, one core idle.
    priority: lambda wc: 1 if wc.batch in model_error_sections() else 0
    params:
        sections=lambda wc: correction_batches()[wc.batch],
        correction=config["correction"],
        model_error=config.get("model_error"),
        span_types=SPAN_TYPES,
    log:
        f"{RESULTS}/logs/correct_section/{{batch}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/correct_section/{{batch}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/correct_section.py"


rule correction:
    """Gather the corrected sections: static W per span type, the convergence log and the
    model-error budget (shift of the corrected W per source, against the correction's size)."""
    input:
        sections=lambda wc: expand(f"{RESULTS}/correction/sections/{{batch}}.parquet", batch=correction_batches()),
        convergence=lambda wc: expand(f"{RESULTS}/correction/sections/{{batch}}_convergence.csv",
                                      batch=correction_batches()),
        model_error=lambda wc: expand(f"{RESULTS}/correction/sections/{{batch}}_model_error.parquet",
                                      batch=correction_batches()),
        profiles=lambda wc: expand(f"{RESULTS}/correction/sections/{{batch}}_profiles.parquet",
                                   batch=correction_batches()),
        spans=expand(f"{RESULTS}/{{span_type}}/spans.parquet", span_type=SPAN_TYPES),
        catenary=config["catenary"],
    output:
        corrected=expand(f"{RESULTS}/{{span_type}}/corrected.parquet", span_type=SPAN_TYPES),
        profiles=expand(f"{RESULTS}/{{span_type}}/corrected_profiles.parquet", span_type=SPAN_TYPES),
        **table("convergence", f"{RESULTS}/correction/convergence.csv", "correction_convergence", CORRECTION, "Convergence per iteration", category=LINE),
        **table("summary", f"{RESULTS}/correction/summary.csv", "correction_summary", CORRECTION, "Correction per span type", category=LINE),
        model_error=f"{RESULTS}/correction/model_error.parquet",
        **table("budget", f"{RESULTS}/correction/model_error_budget.csv", "model_error_budget", CORRECTION, "Model-error budget of the correction", category=LINE),
    params:
        span_types=SPAN_TYPES,
    log:
        f"{RESULTS}/logs/correction.log",
    benchmark:
        f"{RESULTS}/benchmarks/correction.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/correction.py"


rule correction_check:
    """Validation only: corrected and uncorrected W against the campaign's true static W."""
    input:
        corrected=expand(f"{RESULTS}/{{span_type}}/corrected.parquet", span_type=SPAN_TYPES),
        spans=expand(f"{RESULTS}/{{span_type}}/spans.parquet", span_type=SPAN_TYPES),
        truth=f"{RESULTS}/campaign/truth.parquet",
    output:
        **table("summary", f"{RESULTS}/validation/correction_check.csv", "validation_correction", CORRECTION, "Correction vs truth", category=VALIDATION),
    params:
        span_types=SPAN_TYPES,
    log:
        f"{RESULTS}/logs/correction_check.log",
    benchmark:
        f"{RESULTS}/benchmarks/correction_check.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/correction_check.py"
