rule campaign_section:
    """Simulate the recording car over one section of the campaign's truth."""
    input:
        campaign=config["campaign"],
        catenary=config["catenary"],
        pantographs=config["pantographs"],
    output:
        recording=f"{RESULTS}/campaign/sections/{{section}}_recording.parquet",
        truth=f"{RESULTS}/campaign/sections/{{section}}_truth.parquet",
    log:
        f"{RESULTS}/logs/campaign_section/{{section}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/campaign_section/{{section}}.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/campaign_section.py"


rule campaign:
    """Gather the sections: recording (Parquet and CSV), masts and, apart, the truth."""
    input:
        campaign=config["campaign"],
        catenary=config["catenary"],
        recordings=expand(f"{RESULTS}/campaign/sections/{{section}}_recording.parquet", section=CAMPAIGN_SECTIONS),
        truths=expand(f"{RESULTS}/campaign/sections/{{section}}_truth.parquet", section=CAMPAIGN_SECTIONS),
    output:
        recording=f"{RESULTS}/campaign/recording.parquet",
        recording_csv=f"{RESULTS}/campaign/recording.csv",
        masts=f"{RESULTS}/campaign/masts.csv",
        truth=f"{RESULTS}/campaign/truth.parquet",
    log:
        f"{RESULTS}/logs/campaign.log",
    benchmark:
        f"{RESULTS}/benchmarks/campaign.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/campaign.py"


rule ingest:
    """Check the recording and masts files and store them as Parquet."""
    input:
        recording=config["recording"],
        masts=config["masts"],
    output:
        recording=f"{RESULTS}/ingest/recording.parquet",
        masts=f"{RESULTS}/ingest/masts.parquet",
    log:
        f"{RESULTS}/logs/ingest.log",
    benchmark:
        f"{RESULTS}/benchmarks/ingest.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/ingest.py"


checkpoint project:
    """Cut into spans, estimate W at the droppers, report every span used or rejected."""
    input:
        recording=f"{RESULTS}/ingest/recording.parquet",
        masts=f"{RESULTS}/ingest/masts.parquet",
        catenary=config["catenary"],
    output:
        spans=expand(f"{RESULTS}/{{span_type}}/spans.parquet", span_type=SPAN_TYPES),
        report=reported(f"{RESULTS}/spans_report.csv", "spans_report", PROJECTION, "Spans used and rejected", category=LINE),
    params:
        projection=config["projection"],
        span_types=SPAN_TYPES,
    log:
        f"{RESULTS}/logs/project.log",
    benchmark:
        f"{RESULTS}/benchmarks/project.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/project.py"


rule projection_check:
    """Validation only: projected W against the campaign's truth (dynamic W)."""
    input:
        spans=expand(f"{RESULTS}/{{span_type}}/spans.parquet", span_type=SPAN_TYPES),
        truth=f"{RESULTS}/campaign/truth.parquet",
    output:
        summary=reported(f"{RESULTS}/validation/projection_round_trip.csv", "validation_projection", PROJECTION, "Projection vs truth", category=VALIDATION),
    params:
        span_types=SPAN_TYPES,
    log:
        f"{RESULTS}/logs/projection_check.log",
    benchmark:
        f"{RESULTS}/benchmarks/projection_check.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/projection_check.py"
