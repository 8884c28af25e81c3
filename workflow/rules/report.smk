# front_page_inputs() lives in common.smk (the linter wants no functions beside rules).


rule front_page:
    """The HTML report's opening panel: per measured span type, spans used and rejected, the
    correction's convergence, the Table 2 analogue and the diagnosis' verdict."""
    input:
        unpack(front_page_inputs),
        intro="workflow/report/workflow.rst",
        spans_report=f"{RESULTS}/spans_report.csv",
        correction_summary=f"{RESULTS}/correction/summary.csv",
    output:
        front_page=FRONT_PAGE,
    log:
        f"{RESULTS}/logs/front_page.log",
    benchmark:
        f"{RESULTS}/benchmarks/front_page.tsv",
    conda:
        "../envs/catenary.yaml"
    script:
        "../../scripts/front_page.py"
