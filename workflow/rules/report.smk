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


# The report's tables, one rule per table that reported() registered (every rule file is read by
# now): the machine table, which keeps SI, copied in an engineer's units (catenary.report.tables)
# and filed in the report under the table's own caption, span type and stage. A copy takes
# milliseconds: it runs in Snakemake's own process (run:, a local rule on a cluster too), not
# as a job of its own that would pay a Python start-up per table.
for _path, _shown in REPORT_TABLES.items():

    rule:
        name:
            f"report_table_{_shown['caption']}"
        localrule: True
        input:
            table=_path,
        output:
            table=report(report_table(_path), caption=f"../report/{_shown['caption']}.rst",
                         category=_shown["category"], subcategory=_shown["stage"],
                         labels={"result": _shown["title"], "file": os.path.basename(_path)}),
        log:
            report_table_log(_path),
        run:
            from catenary.report.tables import write_engineer_table

            write_engineer_table(input.table, output.table, log[0])
