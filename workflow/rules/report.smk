# front_page_inputs() lives in common.smk (the linter wants no functions beside rules).


rule front_page:
    """The HTML report's opening panel: the mast table's accuracy as each run measured it, per
    measured span type, spans used and rejected, the correction's convergence, the maintenance
    list's headline, what fixing buys, the contact-force verdict per speed, the Table 2 analogue
    and the diagnosis' verdict."""
    input:
        unpack(front_page_inputs),
        intro="workflow/report/workflow.rst",
        spans_report=f"{RESULTS}/spans_report.csv",
        correction_summary=f"{RESULTS}/correction/summary.csv",
        sections=f"{RESULTS}/registration/sections.csv",
    output:
        front_page=FRONT_PAGE,
    params:
        registration=config["registration"],
        contact_force=front_page_limits,
    log:
        f"{RESULTS}/logs/front_page.log",
    benchmark:
        f"{RESULTS}/benchmarks/front_page.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/front_page.py"


use rule front_page as front_page_measurements with:
    input:
        unpack(lambda wildcards: front_page_inputs(wildcards, contact_force=False)),
        intro="workflow/report/workflow.rst",
        spans_report=f"{RESULTS}/spans_report.csv",
        correction_summary=f"{RESULTS}/correction/summary.csv",
        sections=f"{RESULTS}/registration/sections.csv",
    output:
        front_page=FRONT_PAGE_MEASUREMENTS,
    log:
        f"{RESULTS}/logs/front_page_measurements.log",
    benchmark:
        f"{RESULTS}/benchmarks/front_page_measurements.tsv",

