"""Check what a failed cluster run told its user (tests/cluster/run.sh, step 4).

Usage: python tests/cluster/check_failure.py SNAKEMAKE_OUTPUT RESULTS_DIR

The run had a pantographs file with a negative mass, so every ``correct_section`` job fails. Each
"Error in rule" block Snakemake printed must name the rule and the section, and list the rule's
log and the SLURM job's log; the rule log must exist and hold the one-line reason (file, key,
expectation), the SLURM log must exist. Exit status 1 with the missing pieces otherwise.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

RULE = "correct_section"
REASON = ("masses_kg", "expected values ≥ 0", "bad_pantographs.yaml")


def error_blocks(text: str) -> list[str]:
    """The indented blocks that follow each 'Error in rule …:' line."""
    return re.findall(r"^Error in rule .*?:\n(?:    .*\n?)+", text, flags=re.MULTILINE)


def check(output: str, results: Path) -> list[str]:
    problems = []
    blocks = error_blocks(output)
    if not blocks:
        return ["no 'Error in rule' block in Snakemake's output"]
    for block in blocks:
        head = block.splitlines()[0]
        if f"Error in rule {RULE}:" != head:
            problems.append(f"expected the failing rule {RULE}, got: {head}")
            continue
        logs = re.search(r"^    log: (.*?) \(check log file", block, flags=re.MULTILINE)
        if logs is None:
            problems.append(f"{head} lists no log")
            continue
        paths = [Path(p.strip()) for p in logs.group(1).split(",")]
        rule_logs = [p for p in paths if p.parent == results / "logs" / RULE]
        slurm_logs = [p for p in paths if "slurm_logs" in p.parts]
        if len(rule_logs) != 1 or len(slurm_logs) != 1:
            problems.append(f"{head} should list the rule's log and the SLURM log, got {paths}")
            continue
        section = rule_logs[0].stem
        if not re.search(rf"\b{section}\b", slurm_logs[0].as_posix()) or section not in block.split("log:")[0]:
            problems.append(f"{head}: section {section} not named in its outputs and SLURM log path")
        text = rule_logs[0].read_text() if rule_logs[0].is_file() else ""
        if not all(piece in text for piece in REASON):
            problems.append(f"{rule_logs[0]}: expected the reason {REASON}, got {text!r}")
        if not slurm_logs[0].is_file():
            problems.append(f"{slurm_logs[0]}: the SLURM log is missing")
        if not problems:
            print(f"named: rule {RULE}, section {section}, logs {rule_logs[0]} and {slurm_logs[0]}; "
                  f"reason: {text.strip().split(': ', 1)[-1]}")
    return problems


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    found = check(Path(sys.argv[1]).read_text(), Path(sys.argv[2]))
    for problem in found:
        print(f"test-cluster: {problem}", file=sys.stderr)
    sys.exit(1 if found else 0)
