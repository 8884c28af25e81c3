"""Calibration of the per-span posteriors over replicate lines (``make validate``).

Each replicate is the default campaign's N3 line (60 spans, 3 sections of 20) drawn with its own
seed and solved statically as the campaign does it (wires continuous over the masts, a mast's ΔH
shared by its two spans, neighbours with their own random geometry), its W measured with the
white error the maintenance stage assumes (``maintenance.measurement_noise_m``, 0.6 mm). The
laws are identified as the rule does (at N = 2 000, sandwich standard errors), and each span's
posterior is computed twice: with the campaign's true laws as the prior (the best any prior can
do: what is left is the line's own draw and the method) and with the identified laws and their
uncertainty (the rule's prior). What the two give, per input and line, is the measure of the
prior's share in a line's coverage (docs/maintenance.md, *On the default campaign*).
"""

import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pandas as pd
import pytest

from .conftest import ROOT, identify_line, population_laws

N_REPLICATES = 16
N_SAMPLES = 2000
SPAN_TYPE = "N3"
FIRST_SEED = 7000
NOISE_M = 6e-4


def _true_s_opt(spec, catenary, span_type) -> pd.DataFrame:
    """The campaign's laws as an s_opt table: dropper means at the nominal table, T_MW σ the
    section's and the spans' variability in quadrature."""
    from catenary.physics.dropper_table import nominal_dropper_lengths

    st = catenary.span_type(span_type)
    lengths = nominal_dropper_lengths(st, catenary).dropper_lengths_m
    dropper_std = np.broadcast_to(spec.dropper_laws[span_type][1], lengths.shape)
    rows = [{"parameter": f"dropper_{i + 1}_length_m", "mu": m, "sigma": s} for i, (m, s) in
            enumerate(zip(lengths, dropper_std))]
    rows += [{"parameter": name, "mu": mu, "sigma": sigma}
             for name, (mu, sigma) in population_laws(spec, span_type).items()]
    return pd.DataFrame(rows)


def _coverage(post, truth: pd.DataFrame) -> dict:
    names = [n for n in post.names if n in truth.columns]
    cols = [post.names.index(n) for n in names]
    x = truth[names].to_numpy(dtype=float)
    inside = (post.q05[:, cols] <= x) & (x <= post.q95[:, cols])
    return dict(zip(names, inside.mean(axis=0)))


def _replicate(seed: int) -> dict:
    from catenary.physics.config import load_catenary
    from catenary.stages.identification.settings import IdentificationSettings
    from catenary.stages.identification.synthetic import line_deflections
    from catenary.stages.maintenance.posterior import span_posteriors
    from catenary.stages.maintenance.runner import prior_from_s_opt
    from catenary.measurement.truth import load_truth

    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    spec = load_truth(ROOT / "config" / "campaign.yaml", catenary)
    span_type = catenary.span_type(SPAN_TYPE)
    settings = IdentificationSettings.from_mapping({"n_samples": N_SAMPLES})
    line = line_deflections(spec, catenary, SPAN_TYPE, seed=seed)
    rng = np.random.default_rng(seed)
    w = line.w_m + NOISE_M * rng.standard_normal(line.w_m.shape)
    n = span_type.n_droppers
    _, _, result = identify_line(span_type, catenary, w, line.mast_pairs, settings)
    out = {"seed": seed, "status": result.status}
    if result.status != "ok":
        return out
    for kind, table, uncertain in (("true", _true_s_opt(spec, catenary, SPAN_TYPE), False),
                                   ("identified", pd.DataFrame(result.table_rows()), True)):
        prior = prior_from_s_opt(span_type, catenary, table, settings, fault_probability=0.01, law_uncertainty=uncertain)
        post = span_posteriors(prior, w, NOISE_M**2 * np.eye(n), n_samples=4000, seed=14)
        out[kind] = _coverage(post, line.truth)
    return out


@pytest.fixture(scope="module")
def replicates() -> list[dict]:
    # Two processes (the machine's 2 cores), started fresh ("spawn"): each inherits the one BLAS
    # thread tests/conftest.py set in the environment.
    seeds = [FIRST_SEED + r for r in range(N_REPLICATES)]
    with ProcessPoolExecutor(max_workers=min(2, os.cpu_count() or 1),
                             mp_context=multiprocessing.get_context("spawn")) as pool:
        out = [r for r in pool.map(_replicate, seeds) if r["status"] == "ok"]
    table = pd.DataFrame([{"seed": r["seed"], "prior": kind, "input": name, "coverage_90": c}
                          for r in out for kind in ("true", "identified") for name, c in r[kind].items()])
    path = ROOT / "results" / "validation" / "maintenance_replicates.csv"
    path.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(path, index=False, float_format="%.6g")
    return out


@pytest.mark.validation
def test_per_span_intervals_are_calibrated_over_replicate_lines(replicates):
    # Over R lines × 12 inputs × 60 spans the pooled coverage of a calibrated 90 % interval has a
    # binomial standard error of 0.3 % for R = 16 if every span were independent; the spans of a
    # line share its draw (and, with identified laws, their error), which widens it: measured on
    # these replicates, the per-line pooled coverage spreads by 1.7–1.8 %, 0.45 % for the mean of
    # 16. With the true laws the posterior is exact Bayes up to the line's static solution
    # (neighbours random, masts shared): ±1.5 % (3 standard errors; measured 90.3 %). The
    # identified laws may lose what their error costs, bounded at 3 % below nominal, or gain a
    # little: with one run the identification has no noise term, its σ absorb W's error, which
    # the likelihood then counts again (measured 91.0 %); 93 % bounds that by 4 standard errors.
    # Measured too (docs/maintenance.md): all 12 inputs of a line within 85–95 % on 4 of the 16
    # lines with the true laws, 3 with the identified ones.
    assert len(replicates) >= N_REPLICATES - 1, "more than one identification failed"
    true = np.mean([np.mean(list(r["true"].values())) for r in replicates])
    identified = np.mean([np.mean(list(r["identified"].values())) for r in replicates])
    assert abs(true - 0.90) < 0.015, f"true laws: pooled coverage {true:.3f}"
    assert 0.87 < identified < 0.93, f"identified laws: pooled coverage {identified:.3f}"
