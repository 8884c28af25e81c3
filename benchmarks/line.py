"""``make bench-line SPANS=N``: a line of N spans from the recording to the report, on this machine's cores.

The truth is the 1 000-span line's (``config/line/line_1000_campaign.yaml``: N2 and N3 sections of
20 spans alternating, the default campaign's laws and measuring car) with N / 20 sections and seed
N; it is written to ``results/line_<N>/campaign.yaml`` beside the overlay of ``config/config.yaml``
(``config/line/line_1000.yaml``'s, with this line's folders). The run starts from a fresh
``results/line_<N>/`` and has two parts, timed apart:

1. the virtual campaign's simulation (rules ``campaign_section`` and ``campaign``): a user's
   recording is not simulated;
2. every stage a user runs, from the recording to ``report.html``: ingestion, registration,
   projection, correction, inversion, identification, diagnosis, the maintenance posteriors,
   what fixing buys, the contact-force study, the paper's simulations and the report.

Into ``results/benchmarks.json``:

* ``line_<N>_spans_simulation_wall_s``: part 1, Snakemake's start-up included;
  ``line_<N>_spans_campaign_wall_s``: the campaign rule's job alone (its meaning before);
* ``line_<N>_spans_user_wall_s``: part 2, recording to report;
* per rule (stage): ``line_<N>_spans_<rule>_wall_s``, the summed wall time of its jobs (with 2
  cores two jobs overlap, so these add up to more than the whole), ``..._longest_job_s`` and
  ``..._peak_rss_mb``, the largest peak memory of one of its jobs (Snakemake's ``benchmark:``
  record, the process and its children);
* ``line_<N>_spans_peak_rss_mb``: the largest over every job; ``..._peak_pss_mb`` the same of
  the proportional set size (a job that forks workers counts their shared pages once, not once
  per process as its RSS does).

Usage: ``python benchmarks/line.py [--spans N] [--cores C] [--keep] [--part both|simulation|user]``
(``--keep``: reuse what an earlier run left in ``results/line_<N>/`` instead of starting afresh;
``--part simulation`` runs and records part 1 alone, ``--part user`` part 2 alone on the recording an
earlier ``--part simulation`` left, so a long line's simulation can run while nothing else is timed).
"""

from record import ROOT, record  # noqa: I001  (sets one BLAS thread first)

import argparse
import shutil
import subprocess
import time

import yaml

from cluster_resources import measure

TRUTH = ROOT / "config" / "line" / "line_1000_campaign.yaml"
OVERLAY = ROOT / "config" / "line" / "line_1000.yaml"
SECTION_SPANS = 20
SIMULATION = ("campaign_section", "campaign")


def write_line(n_spans: int) -> tuple[str, str]:
    """The campaign truth and the config overlay of a line of ``n_spans`` spans; their paths
    relative to the repository."""
    if n_spans < 2 * SECTION_SPANS or n_spans % SECTION_SPANS:
        raise SystemExit(f"--spans {n_spans}: expected a multiple of {SECTION_SPANS}, at least {2 * SECTION_SPANS} "
                         "(N2 and N3 sections of 20 spans alternate)")
    folder = f"results/line_{n_spans}"
    truth = yaml.safe_load(TRUTH.read_text())
    truth["seed"] = n_spans
    truth["line"]["sections"] = [{"section_id": f"L{k + 1:04d}", "span_type": ("N2", "N3")[k % 2],
                                  "n_spans": SECTION_SPANS} for k in range(n_spans // SECTION_SPANS)]
    overlay = yaml.safe_load(OVERLAY.read_text())
    overlay.update({"results": folder, "campaign": f"{folder}/campaign.yaml",
                    "recording": f"{folder}/campaign/recording.parquet", "masts": f"{folder}/campaign/masts.csv",
                    "survey": f"{folder}/campaign/survey.csv"})
    (ROOT / folder).mkdir(parents=True, exist_ok=True)
    for name, content in (("campaign.yaml", truth), ("config.yaml", overlay)):
        path = ROOT / folder / name
        text = yaml.safe_dump(content, sort_keys=False)
        if not path.exists() or path.read_text() != text:      # kept as it is: a newer file would
            path.write_text(text)                              # make Snakemake simulate again
    return f"{folder}/campaign.yaml", f"{folder}/config.yaml"


def snakemake(overlay: str, cores: int, *targets: str, report: str | None = None) -> float:
    """Run the workflow on ``targets`` (all: none given); its wall time [s]."""
    exe = ROOT / ".venv" / "bin" / "snakemake"
    cmd = [str(exe) if exe.exists() else "snakemake", "--workflow-profile", "workflow/profiles/default",
           "--cores", str(cores), "--configfile", "config/config.yaml", overlay]
    if report:
        cmd += ["--report", report, "--report-after-run"]
    cmd += ["--", *targets] if targets else []
    print("+", " ".join(cmd), flush=True)
    start = time.perf_counter()
    subprocess.run(cmd, cwd=ROOT, check=True)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spans", type=int, default=1000)
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--keep", action="store_true")
    parser.add_argument("--part", choices=("both", "simulation", "user"), default="both")
    args = parser.parse_args()
    results = ROOT / f"results/line_{args.spans}"
    recording = f"results/line_{args.spans}/campaign/recording.parquet"
    if args.part == "user" and not (ROOT / recording).exists():
        raise SystemExit(f"--part user: {recording} is missing; run --part simulation first")
    if results.exists() and not args.keep and args.part != "user":
        shutil.rmtree(results)
    _, overlay = write_line(args.spans)
    key = f"line_{args.spans}_spans"
    figures = {}
    if args.part != "user":
        figures[f"{key}_simulation_wall_s"] = snakemake(overlay, args.cores, recording)
    if args.part != "simulation":
        figures[f"{key}_user_wall_s"] = snakemake(overlay, args.cores, report=f"results/line_{args.spans}/report.html")
    per_rule = measure(results).set_index("rule")
    user_rules = per_rule.loc[~per_rule.index.isin(SIMULATION)]
    if len(user_rules):
        figures[f"{key}_peak_rss_mb"] = float(user_rules["peak_rss_mb"].max())
        figures[f"{key}_peak_pss_mb"] = float(user_rules["peak_pss_mb"].max())
    for rule, row in per_rule.iterrows():
        if args.part != "both" and (rule in SIMULATION) != (args.part == "simulation"):
            continue  # the other part's jobs, recorded when that part ran
        if rule == "campaign":
            figures[f"{key}_campaign_wall_s"] = float(row["total_wall_s"])
        figures[f"{key}_{rule}_wall_s"] = float(row["total_wall_s"])
        figures[f"{key}_{rule}_longest_job_s"] = float(row["max_wall_s"])
        figures[f"{key}_{rule}_peak_rss_mb"] = float(row["peak_rss_mb"])
        figures[f"{key}_{rule}_peak_pss_mb"] = float(row["peak_pss_mb"])
    record(figures)
    print(per_rule.to_string())
    for name, value in figures.items():
        print(f"{name}: {value:.4g}")


if __name__ == "__main__":
    main()
