"""Rule repeatability: the measurement's repeatability of one span type, from its spans measured
by several runs, and the spans whose runs disagree beyond it."""

from catenary.measurement.repeatability import estimate_repeatability
from catenary.plumbing.heap import steady_heap
from catenary.plumbing.logs import rule_logger
from catenary.plumbing.parquet import read_table
from catenary.report.tables import write_shown

steady_heap()  # this process's allocator: freed arrays kept for the next ones (catenary.plumbing.heap)

log = rule_logger("repeatability", snakemake.log[0])
corrected = read_table(snakemake.input.corrected)
result = estimate_repeatability(corrected, level=snakemake.params.level)
result.write(snakemake.output.summary, snakemake.output.spans, snakemake.output.noise)
if result.covariance_m2 is None:
    log.info("%s: no span measured by two converged runs: no repeatability to measure",
             snakemake.wildcards.span_type)
else:
    log.info("%s: repeatability %.3f mm RMS per dropper and run (%s) from %d spans, %d degrees of freedom%s",
             snakemake.wildcards.span_type, 1e3 * result.rms_m, " ".join(f"{1e3 * v:.3f}" for v in result.std_m),
             result.n_spans, result.dof, "" if result.full else " (diagonal only: too few)")
    if result.measured_covariance_m2 is not None:
        log.info("%s: the measurement's own repeatability (measured W minus each run's pass over the runs' mean "
                 "corrected W) %.3f mm RMS per dropper and run, %d degrees of freedom",
                 snakemake.wildcards.span_type, 1e3 * result.measured_rms_m, result.measured_dof)
    for span, why in result.flagged().items():
        log.warning("span %s: %s", span, why)
write_shown(snakemake.output)  # the report's copies of the tables, in an engineer's units
