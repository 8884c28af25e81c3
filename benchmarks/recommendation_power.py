"""``make validate``: each recommendation's predicted power against the power realised by
simulating the recommended measurement (issue [17]).

For each scenario — a worn CW against a T_MW spread, dropper creep against a T_MW spread, a
force offset, a T_CW spread, the car's declared force uncertainty — 117 N2 spans are drawn at the
level of W from the diagnosis' own model (the campaign's effect functions through the fast model,
:func:`catenary.stages.diagnosis.model.simulate_spans`), diagnosed from W alone, and the diagnosis'
questions answered by :func:`catenary.stages.diagnosis.recommend.recommend` (for creep against the T_MW
spread, the first of a few draws where W alone leaves them ambiguous, else — W names creep, or
nothing, on each — the pair as step 1 fitted both). Then, for the recommended
measurement at its recommended extent, ``--replicates`` data sets are drawn from each contrast's
truth — W and the measured quantity on the measured spans, with the measurement's error and its
shared calibration error — and the likelihood-ratio test the contrast stands for is run as the
diagnosis runs it (the null refitted, the null plus the truth's effect refitted, the LR against
the step's Bonferroni level): the realised power is the share of replicates that reject, the
smaller over an ambiguity's two contrasts. A T_CW spread's recommendation is not enough on a
line of 6 sections; it is checked where it would be (one device per span: ``contact_tension``
measured at every span, as on a line of 117 sections).

The exact car's false-alarm rate: ``--null-replicates`` data sets from the fitted model M with
the car's force calibrated (no offset), the force offset tested as the diagnosis tests it.

Writes ``results/validation/recommendation_power.csv`` and the figures to
``results/benchmarks.json``. Usage: ``python benchmarks/recommendation_power.py [--replicates R]
[--null-replicates R0] [scenario ...]``.
"""

from record import ROOT, record  # noqa: I001  (sets one BLAS thread first)

import argparse
import copy
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pandas as pd

from catenary.measurement.channels.observations import LineObservation, Observations
from catenary.measurement.channels.quantities import QUANTITIES, model_columns
from catenary.measurement.channels.settings import MeasurementSettings
from catenary.physics.config import load_catenary
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.measuring import force_influence
from catenary.physics.pantograph import load_pantographs
from catenary.stages.diagnosis.candidates import CANDIDATES
from catenary.stages.diagnosis.locate import mixture_sf
from catenary.stages.diagnosis.model import simulate_spans
from catenary.stages.diagnosis.problem import refit
from catenary.stages.diagnosis.recommend import Extent, pair_question, questions, recommend
from catenary.stages.diagnosis.runner import diagnose, make_sampler
from catenary.stages.diagnosis.settings import DiagnosisSettings
from catenary.stages.identification.settings import IdentificationSettings

N_SPANS = 117
NOISE_M = 0.0006               # the correction's residual per dropper [m] (docs/diagnosis.md)
DECLARED_N = 36.0
#: Two standard uncertainties of the model-error budget's force source (config/config.yaml,
#: model_error source measuring_force: 1 N): the car question's size, as the diagnose rule asks it [N].
CAR_FORCE_N = 2.0 * 1.0
TABLE2 = dict(tension=(20575.0, 0.0), height=(1.388, 0.0065),
              droppers=(0.0067, 0.005, 0.0045, 0.0045, 0.0038, 0.0044, 0.0035, 0.0034, 0.007))
SCENARIOS = {
    "wear_vs_tension": ({"messenger_tension_variability": {"std_n": 300.0},
                         "contact_wire_wear": {"mean_fraction": 0.08, "std_fraction": 0.03}}, "ambiguous", None, 5),
    "creep_vs_tension": ({"dropper_creep": {"mean_m": 0.005, "std_m": 0.006}}, "ambiguous", None, (7, 8, 9)),
    "force_offset": ({}, "measuring_force_offset", None, 11),
    "contact_tension_spread": ({}, "contact_tension_variability", None, 13),
    "car": ({}, "car", CAR_FORCE_N, 17),
}
#: The pair an ambiguous scenario asks about, where W alone does not leave it open on any draw.
PAIRS = {"creep_vs_tension": ("dropper_creep", "messenger_tension_variability")}
_STATE: dict = {}


def _laws(sampler):
    means = np.r_[nominal_dropper_lengths(sampler.models.span_type, sampler.models.catenary).dropper_lengths_m,
                  TABLE2["tension"][0], TABLE2["height"][0]]
    sigmas = np.r_[TABLE2["droppers"], 1e-6, TABLE2["height"][1]]
    return means, sigmas


def _observed(option, extent, y, rng, settings):
    """The measurement of ``option`` on ``extent`` units: values with their error and the shared
    calibration error, NaN elsewhere; a line quantity as one LineObservation."""
    acc = settings.accuracy[option.quantity]
    q = QUANTITIES[option.quantity]
    if q.place == "line":
        return Observations.none(y.shape[0]), (LineObservation(option.quantity, float(y[0, 0]) + acc.std
                                                               * rng.standard_normal(), acc.std),)
    values = np.full((y.shape[0], len(model_columns((option.quantity,)))), np.nan)
    rows = np.arange(y.shape[0]) if option.per == "run" else rng.choice(y.shape[0], size=extent, replace=False)
    values[rows, 0] = y[rows, 0] + acc.std * rng.standard_normal(rows.size) + acc.common_std * rng.standard_normal()
    std = np.where(np.isfinite(values), acc.std, np.nan)
    return Observations((option.quantity,), values, std, (), np.r_[acc.common_std, np.zeros(values.shape[1] - 1)]), ()


def _lr_rejects(index: int) -> tuple[bool, float]:
    """One replicate: draw W and the measurement from ``draw``, refit ``null`` and null plus the
    ``added`` effects, test at ``level``."""
    s = _STATE
    ctx, option, extent, level, seed = s["ctx"], s["option"], s["extent"], s["level"], s["seed"] + index
    draw_effects, draw_theta = s["draw"]
    problem = ctx.problem(tuple(draw_effects))
    means, sigmas = problem.laws(draw_theta)
    w, y = simulate_spans(problem.likelihood.sampler, means, sigmas, problem.magnitudes(draw_theta), N_SPANS,
                          seed=seed, noise_std_m=NOISE_M, observe=(option.quantity,))
    obs, line = _observed(option, extent, y, np.random.default_rng([seed, 1]), s["settings"])
    rep = copy.copy(ctx)
    rep.data, rep.observations = w, Observations(obs.quantities, obs.values, obs.std, line, obs.common_std)
    null_effects, null_theta = s["null"]
    added, added_theta = s["added"]
    settings = ctx.settings
    fit = dict(box=rep.box, base_step=0.1, effect_step=1.0, max_evaluations=settings.max_evaluations,
               xtol=settings.xtol, ftol=settings.ftol, method=settings.optimiser)
    null = refit(rep.problem(tuple(null_effects)), null_theta, **fit)
    alt_problem = rep.problem((*null_effects, *added))
    best = null.j
    for start in (np.r_[null.theta, np.zeros(len(added_theta))], np.r_[null.theta, added_theta]):
        best = max(best, refit(alt_problem, start, **fit).j)
    lr = max(2.0 * (best - null.j), 0.0)
    return bool(mixture_sf(lr, s["n_shift"], s["n_spread"]) < level), float(lr)


def realised(ctx, draw, contrast, option, extent, level, settings, replicates, seed, workers):
    """Share of ``replicates`` drawn from ``draw`` where the contrast's test rejects its null, and
    their LR statistics."""
    null_effects = contrast.null[0]
    added = tuple(e for e in contrast.truth[0] if e not in null_effects)
    n_added = sum(len(CANDIDATES[e].parameters) for e in added)
    _STATE.update(ctx=ctx, draw=draw, null=contrast.null, added=(added, np.asarray(contrast.truth[1])[-n_added:]),
                  option=option, extent=extent, level=level, settings=settings, seed=seed,
                  n_shift=contrast.n_shift, n_spread=contrast.n_spread)
    try:
        with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("fork")) as pool:
            out = list(pool.map(_lr_rejects, range(replicates)))
    finally:
        _STATE.clear()
    return float(np.mean([r for r, _ in out])), np.array([lr for _, lr in out])


def _power_at(ctx, q, option, measurements, k) -> float:
    """Predicted power of ``option`` on ``k`` units (:func:`recommend` on a line of ``k`` of them)."""
    table = recommend(ctx, [q], MeasurementSettings(measurements.accuracy, (option,)), Extent(k, k, k), 0.999999)
    return float(table["power_full"].iloc[0])


def _moderate(ctx, q, option, measurements, extent, level):
    """Settings and extent at which ``option`` is predicted to settle ``q`` with power ≈ 0.5: the
    fewest units reaching 0.5, or — for a run or a line measurement, or an option short of 0.5
    with every unit — every unit at its accuracy scaled by the factor (bisected on a log scale)
    giving 0.5. None when no factor within 10⁻³–10⁴ gives it."""
    only = MeasurementSettings(measurements.accuracy, (option,))
    if option.per not in ("run", "line"):
        table = recommend(ctx, [q], only, extent, 0.5)
        if bool(table["enough"].iloc[0]):
            return only, int(table["extent"].iloc[0]), 1.0
    acc = measurements.accuracy[option.quantity]
    units = extent.available(option.per)

    def power(scale):
        scaled = MeasurementSettings({**measurements.accuracy,
                                      option.quantity: type(acc)(acc.std * scale, acc.common_std)}, (option,))
        return float(recommend(ctx, [q], scaled, extent, 0.999999)["power_full"].iloc[0]), scaled

    # log10 of the accuracy's scale, every unit measured: power(10**lo) ≥ 0.5 > power(10**hi) — a
    # coarser instrument where the option is more than enough, a finer one where it falls short
    lo, hi = (0.0, 4.0) if power(1.0)[0] >= 0.5 else (-3.0, 0.0)
    if power(10 ** lo)[0] < 0.5 or power(10 ** hi)[0] >= 0.5:
        return None, 0, 1.0
    for _ in range(14):
        mid = 0.5 * (lo + hi)
        if power(10 ** mid)[0] >= 0.5:
            lo = mid
        else:
            hi = mid
    return power(10 ** lo)[1], units, float(10 ** lo)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--replicates", type=int, default=60)
    parser.add_argument("--null-replicates", type=int, default=300)
    parser.add_argument("--moderate-replicates", type=int, default=60)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("names", nargs="*")
    args = parser.parse_args()
    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    n2 = catenary.span_type("N2")
    pantograph = load_pantographs(ROOT / "config" / "pantographs.yaml")["measuring"].with_static_force(DECLARED_N)
    influence = force_influence(n2, catenary, pantograph, speed_m_s=40 / 3.6, mode="quasi_static")
    ident = IdentificationSettings.from_mapping({})
    settings = DiagnosisSettings.from_mapping({"n_samples": 4000, "max_steps": 2, "bootstrap_replicates": 200})
    measurements = MeasurementSettings()
    rows, figures = [], {}
    t_all = time.perf_counter()
    for name in args.names or SCENARIOS:
        effects, kind, car, seeds = SCENARIOS[name]
        t0 = time.perf_counter()
        sampler = make_sampler(n2, catenary, ident, settings, tuple(effects), force_influence_m_n=influence)
        means, sigmas = _laws(sampler)
        for seed in np.atleast_1d(seeds):          # the first draw that leaves the question open
            w = simulate_spans(sampler, means, sigmas, effects, N_SPANS, seed=int(seed), noise_std_m=NOISE_M)
            run = diagnose(n2, catenary, w, ident, settings, force_influence_m_n=influence,
                           declared_force_n=DECLARED_N, workers=args.workers)
            asked = [q for q in questions(run, car_force_n=car)
                     if q.kind == kind or (q.kind == "undetectable" and q.asked.startswith(kind))]
            if asked:
                break
            print(f"{name}, draw {seed}: no {kind} question (named {run.named})", flush=True)
        if not asked and name in PAIRS and run.steps:
            # W alone named one of the pair (or neither) on every draw: the pair's question as step 1
            # fitted both — how well a measurement tells them apart is the same question
            q = pair_question(run.steps[0], *PAIRS[name], settings.level)
            asked = [q] if q is not None else []
        seed = int(seed)
        if not asked:
            print(f"{name}: no {kind} question (named {run.named}; steps "
                  f"{[(st.verdict, st.effect, st.runner_up) for st in run.steps]})")
            rows.append({"scenario": name, "question": "", "named_from_w": ", ".join(run.named)})
            continue
        q = asked[0]
        extent = Extent(N_SPANS, N_SPANS if kind == "contact_tension_variability" else 6, N_SPANS + 6)
        table = recommend(run.context, [q], measurements, extent, settings.power)
        best = table[table["recommended"]].iloc[0]
        option = next(o for o in measurements.options if o.name == best["option"])
        powers = [realised(run.context, c.truth, c, option, int(best["extent"]), q.level, measurements,
                           args.replicates, 1000 * seed + 100 * k, args.workers) for k, c in enumerate(q.contrasts)]
        realised_power = min(p for p, _ in powers)
        ratio = realised_power / best["power"] if best["power"] > 0 else float("nan")
        row = {"scenario": name, "draw": seed, "question": q.asked, "kind": q.kind, "level": q.level,
               "named_from_w": ", ".join(run.named), "option": best["option"], "extent": int(best["extent"]),
               "cost_h": float(best["cost_h"]), "predicted_power": float(best["power"]),
               "realised_power": realised_power, "replicates": args.replicates, "ratio": ratio,
               "within_factor_2": bool(0.5 <= ratio <= 2.0), "time_s": time.perf_counter() - t0}
        rows.append(row)
        print(pd.Series(row).to_string(), flush=True)
        figures[f"recommendation_{name}_predicted_power"] = row["predicted_power"]
        figures[f"recommendation_{name}_realised_power"] = realised_power
        if args.moderate_replicates:
            # the same option where it is predicted to be a coin toss (power ≈ 0.5): fewer units, or
            # for a car run or a line measurement a coarser instrument — a test of the prediction
            # itself, which at power ≈ 1 any measurement passes
            moderate, extent_m, scale = _moderate(run.context, q, option, measurements, extent, settings.level)
            if moderate is not None:
                draws = [realised(run.context, c.truth, c, option, extent_m, q.level, moderate, args.moderate_replicates,
                                  5_000_000 + 1000 * seed + 100 * k, args.workers) for k, c in enumerate(q.contrasts)]
                predicted = (float(recommend(run.context, [q], moderate, extent, 0.999999)["power_full"].iloc[0])
                             if scale != 1.0 else _power_at(run.context, q, option, moderate, extent_m))
                got = min(p for p, _ in draws)
                ratio_m = got / predicted if predicted > 0 else float("nan")
                row_m = {"scenario": f"{name}_moderate", "draw": seed, "question": q.asked, "kind": q.kind,
                         "level": q.level, "option": option.name, "extent": extent_m,
                         "accuracy_scale": scale, "predicted_power": predicted, "realised_power": got,
                         "replicates": args.moderate_replicates, "ratio": ratio_m,
                         "within_factor_2": bool(0.5 <= ratio_m <= 2.0)}
                rows.append(row_m)
                print(pd.Series(row_m).to_string(), flush=True)
                figures[f"recommendation_{name}_moderate_predicted_power"] = predicted
                figures[f"recommendation_{name}_moderate_realised_power"] = got
        if kind == "car" and args.null_replicates:
            # the exact car: M itself, with the force calibrated; the offset tested at the step's level
            contrast = q.contrasts[0]
            cal = next(o for o in measurements.options if o.quantity == "measuring_force_n")
            _, lrs = realised(run.context, contrast.null, contrast, cal, 1, q.level, measurements,
                              args.null_replicates, 7_000_000 + seed, args.workers)
            for level in (q.level, 0.05):
                rate = float(np.mean([mixture_sf(x, contrast.n_shift, contrast.n_spread) < level for x in lrs]))
                rows.append({"scenario": "car_exact", "question": f"false alarm at level {level:.3g}",
                             "kind": "false_alarm", "level": level, "option": cal.name,
                             "realised_power": rate, "replicates": args.null_replicates})
                print(f"exact car: false-alarm rate {rate:.3f} at level {level:.3g} ({args.null_replicates} replicates)")
                figures[f"recommendation_car_false_alarm_rate_at_{level:.3g}"] = rate
    out = ROOT / "results" / "validation" / "recommendation_power.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    table = pd.DataFrame(rows)
    if out.exists() and args.names:                 # a partial run replaces its scenarios' rows only
        done = set(table["scenario"]) | ({"car_exact"} if "car" in args.names else set())
        old = pd.read_csv(out)
        table = pd.concat([old[~old["scenario"].isin(done)], table], ignore_index=True)
    table.to_csv(out, index=False, float_format="%.6g")
    figures["recommendation_power_wall_s"] = time.perf_counter() - t_all
    record(figures)


if __name__ == "__main__":
    main()
