if CAMPAIGN_COPIED:

    rule campaign_copy:
        """The campaign's outputs from the copy shipped for these very campaign, catenary and
        pantographs files (its manifest checked when the DAG is built, each file's SHA-256 here):
        the simulation's files without simulating (catenary.measurement.shipped)."""
        input:
            files=[os.path.join(CAMPAIGN_COPY, name) for name in (SHIPPED_MANIFEST, *SHIPPED_FILES)],
            campaign=config["campaign"],
            catenary=config["catenary"],
            pantographs=config["pantographs"],
        output:
            recording=f"{RESULTS}/campaign/recording.parquet",
            recording_csv=f"{RESULTS}/campaign/recording.csv",
            masts=f"{RESULTS}/campaign/masts.csv",
            masts_truth=f"{RESULTS}/campaign/masts_truth.csv",
            truth=f"{RESULTS}/campaign/truth.parquet",
            truth_runs=f"{RESULTS}/campaign/truth_runs.parquet",
            survey=f"{RESULTS}/campaign/survey.csv",
        params:
            folder=lambda wildcards, input: os.path.dirname(input.files[0]),
            why=CAMPAIGN_COPY_WHY,
        priority: 2  # as ingest: on the chain to the correction
        log:
            f"{RESULTS}/logs/campaign.log",
        benchmark:
            f"{RESULTS}/benchmarks/campaign.tsv",
        conda:
            "../envs/catenary.yaml"
        script:
            "../../scripts/campaign_copy.py"

else:

    rule campaign_section:
        """Simulate the recording car over one section of the campaign's truth."""
        input:
            campaign=config["campaign"],
            catenary=config["catenary"],
            pantographs=config["pantographs"],
        output:
            recording=f"{RESULTS}/campaign/sections/{{section}}_recording.parquet",
            truth=f"{RESULTS}/campaign/sections/{{section}}_truth.parquet",
            truth_runs=f"{RESULTS}/campaign/sections/{{section}}_truth_runs.parquet",
        log:
            f"{RESULTS}/logs/campaign_section/{{section}}.log",
        benchmark:
            f"{RESULTS}/benchmarks/campaign_section/{{section}}.tsv",
        conda:
            "../envs/catenary.yaml"
        script:
            "../../scripts/campaign_section.py"


    rule campaign:
        """Gather the sections: recording (Parquet and CSV; every run), masts (the table as given to
        the car, with its planted errors) and, apart, the truth (per span, per span and run, per mast)."""
        input:
            campaign=config["campaign"],
            catenary=config["catenary"],
            recordings=expand(f"{RESULTS}/campaign/sections/{{section}}_recording.parquet", section=CAMPAIGN_SECTIONS),
            truths=expand(f"{RESULTS}/campaign/sections/{{section}}_truth.parquet", section=CAMPAIGN_SECTIONS),
            truth_runs=expand(f"{RESULTS}/campaign/sections/{{section}}_truth_runs.parquet", section=CAMPAIGN_SECTIONS),
        output:
            recording=f"{RESULTS}/campaign/recording.parquet",
            recording_csv=f"{RESULTS}/campaign/recording.csv",
            masts=f"{RESULTS}/campaign/masts.csv",
            masts_truth=f"{RESULTS}/campaign/masts_truth.csv",
            truth=f"{RESULTS}/campaign/truth.parquet",
            truth_runs=f"{RESULTS}/campaign/truth_runs.parquet",
            survey=f"{RESULTS}/campaign/survey.csv",
        priority: 2  # as ingest: on the chain to the correction
        log:
            f"{RESULTS}/logs/campaign.log",
        benchmark:
            f"{RESULTS}/benchmarks/campaign.tsv",
        conda:
            "../envs/catenary.yaml"
        script:
            "../../scripts/campaign.py"


rule ingest:
    """Check the recording file(s) and the masts file and store them as Parquet."""
    input:
        recording=RECORDING_FILES,
        masts=[config["masts"]] if config["masts"] else [],
    output:
        recording=f"{RESULTS}/ingest/recording.parquet",
        masts=f"{RESULTS}/ingest/masts.parquet",
        runs=f"{RESULTS}/ingest/runs.csv",
    # The chain to the correction (ingest → register → project, ≈ 17 s) goes first: left to
    # wait behind the paper-reproduction jobs, it started the correction 15 s late (make run
    # 2026-11-27 01:32).
    priority: 2
    log:
        f"{RESULTS}/logs/ingest.log",
    benchmark:
        f"{RESULTS}/benchmarks/ingest.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/ingest.py"


rule register:
    """Register the mast table onto every run's trace: the odometer's offset, scale and drift per
    section, masts missing from or extra in the table; or find the masts from the trace."""
    input:
        recording=f"{RESULTS}/ingest/recording.parquet",
        masts=f"{RESULTS}/ingest/masts.parquet",
        catenary=config["catenary"],
        pantographs=config["pantographs"],
    output:
        table=f"{RESULTS}/registration/masts_table.csv",
        **table("masts", f"{RESULTS}/registration/masts.csv", "registration_masts", PROJECTION, "Registered masts", category=LINE),
        **table("sections", f"{RESULTS}/registration/sections.csv", "registration_sections", PROJECTION, "Registered sections", category=LINE),
        figure=reported(f"{RESULTS}/registration/residuals.png", "registration_residuals", PROJECTION, "Registration residuals", category=LINE),
    params:
        registration=config["registration"],
        correction=config["correction"],
    # As ingest: on the chain to the correction.
    priority: 2
    # The recording's runs in `threads` processes, one run each at a time (a run's sections follow
    # each other: a recording of one run uses one; the default profile gives it 1 locally).
    threads: 2
    log:
        f"{RESULTS}/logs/register.log",
    benchmark:
        f"{RESULTS}/benchmarks/register.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/register.py"


checkpoint project:
    """Cut every run into spans along its registered masts, estimate W at the droppers, check each
    cut against the trace, report every span of every run used or rejected."""
    input:
        recording=f"{RESULTS}/ingest/recording.parquet",
        table=f"{RESULTS}/registration/masts_table.csv",
        registered_masts=f"{RESULTS}/registration/masts.csv",
        sections=f"{RESULTS}/registration/sections.csv",
        catenary=config["catenary"],
        pantographs=config["pantographs"],
    output:
        spans=expand(f"{RESULTS}/{{span_type}}/spans.parquet", span_type=SPAN_TYPES),
        profiles=expand(f"{RESULTS}/{{span_type}}/profiles.parquet", span_type=SPAN_TYPES),
        **table("report", f"{RESULTS}/spans_report.csv", "spans_report", PROJECTION, "Spans used and rejected", category=LINE),
    params:
        projection=config["projection"],
        registration=config["registration"],
        correction=config["correction"],
        span_types=SPAN_TYPES,
    # As ingest: on the chain to the correction.
    priority: 2
    # The sections cut in worker processes (the same spans for any number): nothing else can
    # run while the line waits for its spans.
    threads: 2
    log:
        f"{RESULTS}/logs/project.log",
    benchmark:
        f"{RESULTS}/benchmarks/project.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/project.py"


rule registration_check:
    """Validation only: registered masts against the campaign's true masts."""
    input:
        masts=f"{RESULTS}/registration/masts.csv",
        masts_truth=f"{RESULTS}/campaign/masts_truth.csv",
        truth_runs=f"{RESULTS}/campaign/truth_runs.parquet",
    output:
        **table("summary", f"{RESULTS}/validation/registration_check.csv", "validation_registration", PROJECTION, "Registration vs truth", category=VALIDATION),
    log:
        f"{RESULTS}/logs/registration_check.log",
    benchmark:
        f"{RESULTS}/benchmarks/registration_check.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/registration_check.py"


rule span_accuracy_check:
    """Validation only (make validate): every true span used under its own id with W near the truth,
    the stated W uncertainty against the error, the table's estimated accuracy against the planted."""
    input:
        report=f"{RESULTS}/spans_report.csv",
        spans=expand(f"{RESULTS}/{{span_type}}/spans.parquet", span_type=SPAN_TYPES),
        sections=f"{RESULTS}/registration/sections.csv",
        masts=f"{RESULTS}/registration/masts.csv",
        masts_truth=f"{RESULTS}/campaign/masts_truth.csv",
        truth=f"{RESULTS}/campaign/truth.parquet",
        truth_runs=f"{RESULTS}/campaign/truth_runs.parquet",
        campaign=config["campaign"],
        catenary=config["catenary"],
    output:
        summary=f"{RESULTS}/validation/span_accuracy.csv",
    log:
        f"{RESULTS}/logs/span_accuracy_check.log",
    benchmark:
        f"{RESULTS}/benchmarks/span_accuracy_check.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/span_accuracy_check.py"


rule projection_check:
    """Validation only: projected W against the campaign's truth (dynamic W of each run)."""
    input:
        spans=expand(f"{RESULTS}/{{span_type}}/spans.parquet", span_type=SPAN_TYPES),
        masts=f"{RESULTS}/registration/masts.csv",
        truth=f"{RESULTS}/campaign/truth.parquet",
        truth_runs=f"{RESULTS}/campaign/truth_runs.parquet",
    output:
        **table("summary", f"{RESULTS}/validation/projection_round_trip.csv", "validation_projection", PROJECTION, "Projection vs truth", category=VALIDATION),
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
