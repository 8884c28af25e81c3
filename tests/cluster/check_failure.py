"""Check what a failed cluster run told its user (tests/cluster/run.sh, step 4).

Usage: python tests/cluster/check_failure.py SNAKEMAKE_OUTPUT RESULTS_DIR

The run had a pantographs file with a negative mass, so the first job that reads it fails: the
registration, which predicts the measuring pantograph's lag (``register``, one job for the line).
Each "Error in rule" block Snakemake printed must name the rule and list the rule's log and the
SLURM job's log; a job with a wildcard (a log in ``logs/<rule>/<wildcard>.log``) must also name
its wildcard in its outputs and in the SLURM log's path. The rule log must exist and hold the
one-line reason (file, key, expectation), the SLURM log must exist. Exit status 1 with the
missing pieces otherwise.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

RULE = "register"
REASON = ("masses_kg", "expected values ≥ 0", "bad_pantographs.yaml")


def error_blocks(text: str) -> list[str]:
    """The indented blocks that follow each 'Error in rule …:' line."""
    return re.findall(r"^Error in rule .*?:\n(?:    .*\n?)+", text, flags=re.MULTILINE)


def check(output: str, results: Path, rule: str = RULE) -> list[str]:
    """The problems with what the failed run told its user (empty: all said)."""
    problems = []
    blocks = error_blocks(output)
    if not blocks:
        return ["no 'Error in rule' block in Snakemake's output"]
    for block in blocks:
        head = block.splitlines()[0]
        if f"Error in rule {rule}:" != head:
            problems.append(f"expected the failing rule {rule}, got: {head}")
            continue
        logs = re.search(r"^    log: (.*?) \(check log file", block, flags=re.MULTILINE)
        if logs is None:
            problems.append(f"{head} lists no log")
            continue
        paths = [Path(p.strip()) for p in logs.group(1).split(",")]
        logs_dir = results / "logs"
        rule_logs = [p for p in paths if p == logs_dir / f"{rule}.log" or p.parent == logs_dir / rule]
        slurm_logs = [p for p in paths if "slurm_logs" in p.parts]
        if len(rule_logs) != 1 or len(slurm_logs) != 1:
            problems.append(f"{head} should list the rule's log and the SLURM log, got {paths}")
            continue
        wildcard = rule_logs[0].stem if rule_logs[0].parent == logs_dir / rule else None
        if wildcard is not None and (not re.search(rf"\b{wildcard}\b", slurm_logs[0].as_posix())
                                     or wildcard not in block.split("log:")[0]):
            problems.append(f"{head}: {wildcard} not named in its outputs and SLURM log path")
        text = rule_logs[0].read_text() if rule_logs[0].is_file() else ""
        if not all(piece in text for piece in REASON):
            problems.append(f"{rule_logs[0]}: expected the reason {REASON}, got {text!r}")
        if not slurm_logs[0].is_file():
            problems.append(f"{slurm_logs[0]}: the SLURM log is missing")
        if not problems:
            print(f"named: rule {rule}{f', {wildcard}' if wildcard else ''}, logs {rule_logs[0]} and {slurm_logs[0]}; "
                  f"reason: {text.strip().split(': ', 1)[-1]}")
    return problems


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    found = check(Path(sys.argv[1]).read_text(), Path(sys.argv[2]))
    for problem in found:
        print(f"test-cluster: {problem}", file=sys.stderr)
    sys.exit(1 if found else 0)
