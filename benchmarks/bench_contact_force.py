"""Contact-force replicates: wall time of one random 10-span N2 section run at 300 km/h.

The section is drawn from spreads of the paper's Table 2 order (droppers 5 mm, T_MW 818 N,
ΔH 6.5 mm) by the sampler the rule uses, assembled, and run by the reference 2-mass pantograph
from the first mast until one span after the analysis window
(`catenary.stages.contact_force.runs.run_section`), statistics over spans 4–7. The first replicate (compiling and loading the kernel) is not counted.

When a default run has left its jobs' ``benchmark:`` records in ``results/benchmarks/`` (``make
run``), the contact-force rules' own wall time is recorded too: the sum over the batch and
gather jobs of both span types (``contact_force_default_run_jobs_s``, CPU time on one core each)
and the longest batch (``contact_force_default_run_longest_batch_s``).
"""

from record import ROOT, record  # noqa: I001  (sets one BLAS thread first)

import dataclasses
import time

from catenary.physics.config import load_catenary
from catenary.physics.pantograph import load_pantographs
from catenary.stages.contact_force.draws import draw_section, replicate_seeds
from catenary.stages.contact_force.laws import design_laws
from catenary.stages.contact_force.runs import run_section
from catenary.stages.contact_force.settings import ContactForceSettings

REPLICATES = 4


def main() -> None:
    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    n2 = catenary.span_type("N2")
    pantograph = load_pantographs(ROOT / "config" / "pantographs.yaml")["reference_2mass"]
    settings = ContactForceSettings.from_mapping({"n_spans": 10, "analysis_masts": [3, 7], "speeds_kmh": [300.0]})
    laws = dataclasses.replace(design_laws(n2, catenary).with_spreads(dropper_sigma_m=0.005,
                                                                      messenger_tension_sigma_n=818.0),
                               system_height_sigma_m=0.0065)
    times = []
    for r in range(REPLICATES + 1):
        t0 = time.perf_counter()
        section, _ = draw_section(laws, n2, catenary, settings.n_spans, replicate_seeds(settings.seed, r, laws))
        _, rows = run_section(section, catenary, pantograph, settings, (300.0,))
        times.append(time.perf_counter() - t0)
    per_replicate = sorted(times[1:])[len(times[1:]) // 2]
    print(f"one 10-span section at 300 km/h: {per_replicate:.2f} s (median of {REPLICATES}; first {times[0]:.2f} s)")
    figures = {"contact_force_replicate_10span_300kmh_s": per_replicate}
    if (ROOT / "results" / "benchmarks" / "contact_force_batch").is_dir():
        from cluster_resources import measure

        jobs = measure(ROOT / "results").set_index("rule")
        rules = [r for r in ("contact_force_batch", "contact_force") if r in jobs.index]
        figures["contact_force_default_run_jobs_s"] = float(jobs.loc[rules, "total_wall_s"].sum())
        figures["contact_force_default_run_longest_batch_s"] = float(jobs.loc["contact_force_batch", "max_wall_s"])
        print(f"default run: contact-force jobs {figures['contact_force_default_run_jobs_s']:.0f} s in all, "
              f"longest batch {figures['contact_force_default_run_longest_batch_s']:.1f} s")
    record(figures)


if __name__ == "__main__":
    main()
