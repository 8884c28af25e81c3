# identification_outputs() lives in common.smk (the linter wants no functions beside rules).


rule repeatability:
    """The measurement's repeatability of one span type from its spans measured by several runs
    (none with one run), and the spans whose runs disagree beyond it."""
    input:
        corrected=f"{RESULTS}/{{span_type}}/corrected.parquet",
    output:
        **table("summary", f"{RESULTS}/{{span_type}}/repeatability/summary.csv", "repeatability", IDENTIFICATION, "Repeatability"),
        spans=f"{RESULTS}/{{span_type}}/repeatability/spans.csv",
        noise=f"{RESULTS}/{{span_type}}/repeatability/noise.json",
    params:
        level=config["repeatability"]["level"],
    log:
        f"{RESULTS}/logs/repeatability/{{span_type}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/repeatability/{{span_type}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/repeatability.py"


rule identify:
    """Stochastic identification of one span type (paper §3–4.2): s_opt with standard
    errors, the J trace, Gaussian vs kernel estimates (Fig. 7), Henze–Zirkler tests, the 98 %
    band of the CW deflection (Fig. 10) and a report."""
    input:
        corrected=f"{RESULTS}/{{span_type}}/corrected.parquet",
        noise=f"{RESULTS}/{{span_type}}/repeatability/noise.json",
        model_error=f"{RESULTS}/correction/model_error.parquet",
        spans=f"{RESULTS}/{{span_type}}/spans.parquet",
        survey=SURVEY_FILES,
        catenary=config["catenary"],
    output:
        **table("s_opt", f"{RESULTS}/{{span_type}}/identification/s_opt.csv", "s_opt", IDENTIFICATION, "Table 2: s_opt"),
        trace=f"{RESULTS}/{{span_type}}/identification/trace.parquet",
        estimators=reported(f"{RESULTS}/{{span_type}}/identification/estimators.png", "estimators", IDENTIFICATION, "Fig. 7: estimators"),
        normality=f"{RESULTS}/{{span_type}}/identification/normality.json",
        band=reported(f"{RESULTS}/{{span_type}}/identification/band.png", "band", IDENTIFICATION, "Fig. 10: 98 % band"),
        report=f"{RESULTS}/{{span_type}}/identification/identification.md",
        model_error=f"{RESULTS}/{{span_type}}/identification/model_error.csv",
    params:
        identification=span_type_settings("identification"),
        model_error_enabled=config.get("model_error", {}).get("enabled", False),
        measurements=config.get("measurements"),
        correction=config["correction"],
    # `threads` processes share each of the optimiser's J evaluations, then the standard errors'
    # points and the tasks after s_opt (the same answers for any number; 5 000 spans: 18.3 s on
    # one, 12.0–12.3 s on two). Local runs give it one (workflow/profiles/default: the two span
    # types' jobs side by side); a cluster job has cpus_per_task 2.
    threads: 2
    log:
        f"{RESULTS}/logs/identify/{{span_type}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/identify/{{span_type}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/identify.py"


rule identify_explained:
    """The laws of one span type identified again without the spans the final model does not
    explain (diagnosis/spans.csv), beside those of every span (laws_comparison.csv): what the
    later stages use unless diagnosis.later_stages_laws is all_spans."""
    input:
        corrected=f"{RESULTS}/{{span_type}}/corrected.parquet",
        noise=f"{RESULTS}/{{span_type}}/repeatability/noise.json",
        model_error=f"{RESULTS}/correction/model_error.parquet",
        s_opt=f"{RESULTS}/{{span_type}}/identification/s_opt.csv",
        spans=f"{RESULTS}/{{span_type}}/diagnosis/spans.csv",
        projected=f"{RESULTS}/{{span_type}}/spans.parquet",
        survey=SURVEY_FILES,
        catenary=config["catenary"],
    output:
        s_opt=f"{RESULTS}/{{span_type}}/identification/s_opt_explained.csv",
        **table("comparison", f"{RESULTS}/{{span_type}}/identification/laws_comparison.csv", "laws_comparison", IDENTIFICATION, "Laws with and without the unexplained spans"),
    params:
        identification=span_type_settings("identification"),
        model_error_enabled=config.get("model_error", {}).get("enabled", False),
        measurements=config.get("measurements"),
        correction=config["correction"],
    log:
        f"{RESULTS}/logs/identify_explained/{{span_type}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/identify_explained/{{span_type}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/identify_explained.py"


rule identification_check:
    """Validation only: identified laws against the realized truth of the spans used (z-scores)."""
    input:
        s_opt=expand(f"{RESULTS}/{{span_type}}/identification/s_opt.csv", span_type=SPAN_TYPES),
        corrected=expand(f"{RESULTS}/{{span_type}}/corrected.parquet", span_type=SPAN_TYPES),
        truth=f"{RESULTS}/campaign/truth.parquet",
    output:
        **table("summary", f"{RESULTS}/validation/identification_check.csv", "validation_identification", IDENTIFICATION, "Identification vs truth", category=VALIDATION),
    params:
        span_types=SPAN_TYPES,
    log:
        f"{RESULTS}/logs/identification_check.log",
    benchmark:
        f"{RESULTS}/benchmarks/identification_check.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/identification_check.py"


rule repeatability_check:
    """Validation only: the repeatability estimated against the truth's split of the run-to-run
    scatter into the planted sensor noise and what the correction leaves."""
    input:
        summaries=expand(f"{RESULTS}/{{span_type}}/repeatability/summary.csv", span_type=SPAN_TYPES),
        corrected=expand(f"{RESULTS}/{{span_type}}/corrected.parquet", span_type=SPAN_TYPES),
        spans=expand(f"{RESULTS}/{{span_type}}/spans.parquet", span_type=SPAN_TYPES),
        masts=f"{RESULTS}/registration/masts.csv",
        truth=f"{RESULTS}/campaign/truth.parquet",
        truth_runs=f"{RESULTS}/campaign/truth_runs.parquet",
    output:
        **table("summary", f"{RESULTS}/validation/repeatability_check.csv", "validation_repeatability", IDENTIFICATION, "Repeatability vs truth", category=VALIDATION),
    params:
        span_types=SPAN_TYPES,
    log:
        f"{RESULTS}/logs/repeatability_check.log",
    benchmark:
        f"{RESULTS}/benchmarks/repeatability_check.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/repeatability_check.py"
