# diagnosis_outputs() lives in common.smk (the linter wants no functions beside rules).


rule diagnose:
    """Discrepancy workflow of one span type: locate where the identification model and the
    corrected W disagree, name the missing effect among the candidates, add it, show the gap
    shrink; then check every span (W and its whole profile) and section against the final model
    and diagnose again without the spans it does not explain (docs/diagnosis.md)."""
    input:
        corrected=f"{RESULTS}/{{span_type}}/corrected.parquet",
        profiles=f"{RESULTS}/{{span_type}}/corrected_profiles.parquet",
        spans=f"{RESULTS}/{{span_type}}/spans.parquet",
        survey=SURVEY_FILES,
        model_error=f"{RESULTS}/correction/model_error.parquet",
        catenary=config["catenary"],
        pantographs=config["pantographs"],
    output:
        **table("findings", f"{RESULTS}/{{span_type}}/diagnosis/findings.csv", "findings", DIAGNOSIS, "Findings per step"),
        **table("candidates", f"{RESULTS}/{{span_type}}/diagnosis/candidates.csv", "candidates", DIAGNOSIS, "Every candidate"),
        steps=f"{RESULTS}/{{span_type}}/diagnosis/steps.json",
        residuals=reported(f"{RESULTS}/{{span_type}}/diagnosis/residuals.png", "residuals", DIAGNOSIS, "Residuals per dropper"),
        eigenvalues=reported(f"{RESULTS}/{{span_type}}/diagnosis/eigenvalues.png", "eigenvalues", DIAGNOSIS, "Whitened eigenvalues"),
        qq=reported(f"{RESULTS}/{{span_type}}/diagnosis/mahalanobis_qq.png", "mahalanobis_qq", DIAGNOSIS, "Mahalanobis QQ"),
        scores=reported(f"{RESULTS}/{{span_type}}/diagnosis/score_screen.png", "score_screen", DIAGNOSIS, "Score screen"),
        summary=f"{RESULTS}/{{span_type}}/diagnosis/summary.md",
        **table("spans", f"{RESULTS}/{{span_type}}/diagnosis/spans.csv", "diagnosis_spans", DIAGNOSIS, "Every span: explained or not"),
        sections=f"{RESULTS}/{{span_type}}/diagnosis/sections.csv",
        spans_figure=reported(f"{RESULTS}/{{span_type}}/diagnosis/spans.png", "diagnosis_spans_figure", DIAGNOSIS, "Unexplained spans along the line"),
        span_effects=f"{RESULTS}/{{span_type}}/diagnosis/span_effects.csv",
        **table("recommendations", f"{RESULTS}/{{span_type}}/diagnosis/recommendations.csv", "recommendations", DIAGNOSIS, "What to measure next"),
    params:
        effects_modules=config.get("effects_modules", []),
        measurements=config.get("measurements"),
        model_error=config.get("model_error"),
        maintenance=config.get("maintenance"),
        identification=span_type_settings("identification"),
        diagnosis=span_type_settings("diagnosis"),
        correction=config["correction"],
        model_error_enabled=config.get("model_error", {}).get("enabled", False),
    threads: 2
    # The longest chain after the correction (diagnosis ≈ 180 s, then the contact-force batches
    # that draw what it named): started before the identifications and the maintenance, which fill
    # the cores after it, not left to end the run alone (make run 2026-11-26 19:18: 40 s of tail).
    priority: 1
    log:
        f"{RESULTS}/logs/diagnose/{{span_type}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/diagnose/{{span_type}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/diagnose.py"


rule diagnosis_check:
    """Validation only: what the diagnosis named against the campaign's hidden effects."""
    input:
        findings=expand(f"{RESULTS}/{{span_type}}/diagnosis/findings.csv", span_type=SPAN_TYPES),
        campaign=config["campaign"],
        truth=f"{RESULTS}/campaign/truth.parquet",
        catenary=config["catenary"],
    output:
        **table("summary", f"{RESULTS}/validation/diagnosis_check.csv", "validation_diagnosis", DIAGNOSIS, "Diagnosis vs truth", category=VALIDATION),
    params:
        span_types=SPAN_TYPES,
    log:
        f"{RESULTS}/logs/diagnosis_check.log",
    benchmark:
        f"{RESULTS}/benchmarks/diagnosis_check.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/diagnosis_check.py"


rule spans_check:
    """Validation only: the per-span check and the maintenance list against the spans an effect
    no catalogue lists touched in the campaign (flagged, others flagged, positions, actions)."""
    input:
        spans=expand(f"{RESULTS}/{{span_type}}/diagnosis/spans.csv", span_type=SPAN_TYPES),
        sections=expand(f"{RESULTS}/{{span_type}}/diagnosis/sections.csv", span_type=SPAN_TYPES),
        listed=expand(f"{RESULTS}/{{span_type}}/maintenance/maintenance.csv", span_type=SPAN_TYPES),
        campaign=config["campaign"],
        truth=f"{RESULTS}/campaign/truth.parquet",
        catenary=config["catenary"],
    output:
        **table("summary", f"{RESULTS}/validation/spans_check.csv", "validation_spans", DIAGNOSIS, "Unexplained spans vs truth", category=VALIDATION),
    params:
        span_types=SPAN_TYPES,
        campaign=lambda wc: os.path.basename(config["campaign"]).removesuffix(".yaml").removesuffix("_campaign"),
    log:
        f"{RESULTS}/logs/spans_check.log",
    benchmark:
        f"{RESULTS}/benchmarks/spans_check.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/spans_check.py"
