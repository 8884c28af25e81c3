MAINTENANCE = "8 Maintenance (per-span posteriors)"


rule maintenance:
    """Each span's posterior given its corrected W with the identified laws as the prior (the
    paper's Bayesian step), the probability of each input lying outside tolerance, the list of
    spans and inputs to act on, and the population's posterior band beside the prior band of
    Fig. 10 with its leave-one-out coverage."""
    input:
        corrected=f"{RESULTS}/{{span_type}}/corrected.parquet",
        s_opt=later_laws,
        spans=f"{RESULTS}/{{span_type}}/diagnosis/spans.csv",
        sections=f"{RESULTS}/{{span_type}}/diagnosis/sections.csv",
        noise=f"{RESULTS}/{{span_type}}/repeatability/noise.json",
        model_error=f"{RESULTS}/correction/model_error.parquet",
        catenary=config["catenary"],
    output:
        posterior=f"{RESULTS}/{{span_type}}/maintenance/posterior.parquet",
        **table("listed", f"{RESULTS}/{{span_type}}/maintenance/maintenance.csv", "maintenance_list", MAINTENANCE, "Maintenance list"),
        figure=reported(f"{RESULTS}/{{span_type}}/maintenance/chainage.png", "maintenance_chainage", MAINTENANCE, "Deviations along the line"),
        band=f"{RESULTS}/{{span_type}}/maintenance/population_band.csv",
        **table("band_coverage", f"{RESULTS}/{{span_type}}/maintenance/population_coverage.csv", "maintenance_band_coverage", MAINTENANCE, "Posterior band: coverage"),
        band_figure=reported(f"{RESULTS}/{{span_type}}/maintenance/population_band.png", "maintenance_band", MAINTENANCE, "Posterior band"),
    params:
        identification=span_type_settings("identification"),
        maintenance=config.get("maintenance"),
        model_error_enabled=config.get("model_error", {}).get("enabled", False),
    # The posteriors and the band's coverages in worker processes over blocks of spans (the
    # answer the same for any number): the per-type serial part of a long line's run.
    threads: 2
    log:
        f"{RESULTS}/logs/maintenance/{{span_type}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/maintenance/{{span_type}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/maintenance.py"


rule maintenance_check:
    """Validation only: per-span posteriors against the campaign's truth (90 % coverage per
    input, against the dropper-only inversion) and the list's precision and recall."""
    input:
        posterior=expand(f"{RESULTS}/{{span_type}}/maintenance/posterior.parquet", span_type=SPAN_TYPES),
        inversion=expand(f"{RESULTS}/{{span_type}}/inversion/droppers.parquet", span_type=SPAN_TYPES),
        truth=f"{RESULTS}/campaign/truth.parquet",
    output:
        **table("coverage", f"{RESULTS}/validation/maintenance_check.csv", "validation_maintenance", MAINTENANCE, "Posteriors vs truth", category=VALIDATION),
        roc=f"{RESULTS}/validation/maintenance_list_check.csv",
    params:
        span_types=SPAN_TYPES,
    log:
        f"{RESULTS}/logs/maintenance_check.log",
    benchmark:
        f"{RESULTS}/benchmarks/maintenance_check.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/maintenance_check.py"


rule maintenance_repair:
    """What fixing buys: the contact force over the sections holding listed spans, with their
    posterior geometry as measured and with the listed droppers set back to nominal, at the
    operating speeds (EN 50367 criteria and margins)."""
    input:
        posterior=f"{RESULTS}/{{span_type}}/maintenance/posterior.parquet",
        listed=f"{RESULTS}/{{span_type}}/maintenance/maintenance.csv",
        catenary=config["catenary"],
        pantographs=config["pantographs"],
    output:
        table=f"{RESULTS}/{{span_type}}/maintenance/repair.csv",
        **table("summary", f"{RESULTS}/{{span_type}}/maintenance/repair_summary.csv", "maintenance_repair", MAINTENANCE, "What fixing buys"),
    params:
        contact_force=span_type_settings("contact_force"),
    # The repair windows' runs in worker processes (the same table for any number).
    threads: 2
    log:
        f"{RESULTS}/logs/maintenance_repair/{{span_type}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/maintenance_repair/{{span_type}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/maintenance_repair.py"
