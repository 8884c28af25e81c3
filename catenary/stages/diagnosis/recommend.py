"""What to measure next: for every question W alone leaves open, the cheapest measurement that settles it.

The diagnosis leaves three kinds of question open:

* **ambiguous** — at a step, two candidates A and B explain W about equally well (their BICs
  within the margin). Two fitted models compete: M + A and M + B.
* **undetectable** — a candidate whose realistic size is below what W can detect (the free
  means absorb it: a T_CW spread, a force offset, a common creep). The question is whether it is
  there at its realistic size: M + C against M.
* **the car** — W alone cannot tell the measuring car's force from the declared one (a force
  offset moves W as the free means do). The question is whether the car pushes by as much as its
  declared uncertainty allows (``bound`` standard uncertainties of the model-error budget's force
  source) more or less than declared: M + the offset against M.

Each question is one or two *contrasts*: a truth (a fitted model, or M with the effect at the
size asked about) that a measurement must tell from a null model refitted to it. A measurement
(:class:`catenary.measurement.channels.settings.MeasurementOption`) adds quantities beside W on some spans
(:mod:`catenary.measurement.channels.quantities`); the joint law of W and the quantities under each model is
the Gaussian of its model sample, on the diagnosis' own design. The likelihood-ratio test that
would settle the contrast has the non-centrality

    λ = ⟨Δ, Δ⟩ − gᵀ G⁺ g,

the Fisher norm of the change Δ of the joint (mean, covariance) from the null to the truth minus
what the null's coordinates absorb (the secant non-centrality of the detectable magnitudes,
:func:`.locate.secant_noncentrality`), summed over the spans with and without the measurement:
``⟨a, b⟩ = Σ_p n_p [a_mᵀ Σ_p⁻¹ b_m + ½ tr(Σ_p⁻¹ a_Σ Σ_p⁻¹ b_Σ)]`` over the groups p of ``n_p``
spans that carry the same columns, Σ_p the null's covariance of those columns plus the
measurement's variance. An error every value shares (``common_std`` s: a calibration) is one
more coordinate the null may move, at the price of its prior: ``G`` gains ``1/s²`` on its
diagonal, so the mean of that quantity is evidence only beyond its calibration. A line quantity
(the measuring force) is one more unit with its single column.

The power at the diagnosis' level (Bonferroni over the step's candidates) follows from λ and the
tested parameters (:func:`.locate.lr_power`); an ambiguity needs both contrasts settled, so its
power is the smaller of the two. For each option, the smallest extent (spans, sections or masts
measured; a car run covers every span) that reaches the configured power is found (λ grows with
the extent), and its cost is the extent times the hours of one unit; the recommendation is the
cheapest option that reaches the power, or, if none does, the one with the highest power,
marked as not enough.

Measurements already made (the diagnosis' observations: a wear channel, a survey) are groups of
the same sum: a question they settle with the configured power is not asked again (the
diagnosis' own test, which reads them, answers it), and an option measuring a quantity already
measured is not offered.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from catenary.measurement.channels.quantities import QUANTITIES, model_columns
from catenary.measurement.channels.settings import MeasurementOption, MeasurementSettings
from catenary.plumbing.workers import map_each
from .candidates import CANDIDATES, format_magnitude
from .locate import lr_power
from .refits import moment_steps

__all__ = ["NOT_ASKED", "Contrast", "Extent", "Question", "RECOMMENDATION_COLUMNS", "describe_measurement", "noncentrality",
           "pair_question", "questions", "recommend", "recommendation_text"]

#: Columns of ``recommendations.csv`` (one row per question and option).
RECOMMENDATION_COLUMNS = ("question", "kind", "step", "asked", "option", "quantity", "per", "extent", "available",
                          "cost_h", "power", "power_full", "enough", "recommended")


@dataclass(frozen=True)
class Contrast:
    """A truth a measurement must tell from a null model refitted to it.

    Attributes
    ----------
    label : str
        What the test asks, in words.
    truth, null : (tuple of str, numpy.ndarray)
        Each model's effects and coordinates (:attr:`.problem.JointProblem.names`).
    n_shift, n_spread : int
        Interior and boundary parameters the test has.
    """

    label: str
    truth: tuple
    null: tuple
    n_shift: int
    n_spread: int


@dataclass(frozen=True)
class Question:
    """One question W alone leaves open.

    Attributes
    ----------
    kind : {"ambiguous", "undetectable", "car"}
    step : int
        The diagnosis step it arises at.
    asked : str
        The question in words.
    contrasts : tuple of Contrast
        All must be settled.
    level : float
        Level of each test (the step's Bonferroni level).
    """

    kind: str
    step: int
    asked: str
    contrasts: tuple[Contrast, ...]
    level: float


@dataclass(frozen=True)
class Extent:
    """How many units of each kind the line offers: its spans of the type, sections, masts."""

    spans: int
    sections: int
    masts: int

    def available(self, per: str) -> int:
        return {"run": 1, "line": 1, "span": self.spans, "section": self.sections,
                "mast": min(self.masts, self.spans)}[per]

    @classmethod
    def of_line(cls, n_spans: int, places) -> "Extent":
        """The line of ``n_spans`` diagnosed spans whose places (``section_id``) are ``places``:
        a mast at the start of each span and one more at each section's end."""
        n_sections = max(int(places["section_id"].nunique()), 1)
        return cls(n_spans, n_sections, n_spans + n_sections)


#: Candidates no question is asked about: the negative control, which the projection onto the
#: chord removes by design (:mod:`.candidates`), so that nothing about it needs settling.
NOT_ASKED = ("steady_arm_height_difference",)


def describe_measurement(quantity: str, per: str, extent: int, cost_h: float) -> str:
    """The measurement in words: what, on how many units, and its cost."""
    what = QUANTITIES[quantity].label
    where = {"run": "on one car run over every span", "line": "once",
             "span": f"in {extent} span{'s' * (extent != 1)}", "section": f"at {extent} tensioning device"
             f"{'s' * (extent != 1)}", "mast": f"at {extent} mast{'s' * (extent != 1)}"}[per]
    return f"{what} {where} ({cost_h:.3g} h)"


def recommendation_text(row) -> str:
    """One recommendation (a row of ``recommendations.csv``) in words, with its predicted power."""
    text = describe_measurement(row["quantity"], row["per"], int(row["extent"]), float(row["cost_h"]))
    if bool(row["enough"]):
        return f"{text}: predicted power {float(row['power']):.2f}"
    every = "" if row["per"] in ("run", "line") else f" with every {row['per']} the line has"
    return f"{text}: predicted power only {float(row['power_full']):.2f}{every}, short of what is asked"


def questions(run, *, car_force_n: float | None = None) -> list[Question]:
    """The open questions of a diagnosis run (:class:`.runner.DiagnosisRun`): its ambiguous step,
    the candidates undetectable at their realistic size after its last step, and, with
    ``car_force_n`` (the force offset the car's declared uncertainty allows [N]), the car."""
    out: list[Question] = []
    for st in run.steps:
        if st.verdict == "ambiguous":
            q = pair_question(st, st.effect, st.runner_up, run.settings.level)
            if q is not None:
                out.append(q)
    last = run.steps[-1] if run.steps else None
    final = (tuple(run.final_problem.effects), np.asarray(run.final.theta, dtype=float))
    n_tests = len(last.candidates) if last is not None else len(run.settings.candidates)
    level = run.settings.level / max(n_tests, 1)
    step = last.step if last is not None else 0
    if last is not None:
        for c in last.candidates:
            if c.effect in final[0] or c.effect in NOT_ASKED or (c.effect == "measuring_force_offset"
                                                                 and car_force_n is not None):
                continue
            for k, p in enumerate(CANDIDATES[c.effect].parameters):
                if not c.detectable.get(p.name, 0.0) > p.realistic:
                    continue
                out.append(Question("undetectable", step, f"{c.effect} {p.name} at {format_magnitude(p.realistic, p.unit, name=p.name)}",
                                    (_effect_at(final, c.effect, k, p.realistic, p.kind),), level))
    if car_force_n is not None and "measuring_force_offset" not in final[0] and \
            "measuring_force_offset" in run.settings.candidates:
        p = CANDIDATES["measuring_force_offset"].parameters[0]
        out.append(Question("car", step, f"a measuring force {car_force_n:.2g} N off the declared one",
                            (_effect_at(final, "measuring_force_offset", 0, car_force_n, p.kind),), level))
    return out


def pair_question(step, a: str, b: str, level: float) -> Question | None:
    """Which of two candidates of a diagnosis step (:class:`.runner.DiagnosisStep`) the data hold:
    M + ``a`` and M + ``b`` as the step fitted them, each a truth the other must be told from, at
    the step's Bonferroni level (``level`` over its candidates). None when a refit is missing."""
    tests = {c.effect: c for c in step.candidates}
    if a not in tests or b not in tests or tests[a].theta is None or tests[b].theta is None:
        return None
    base = tuple(step.model_effects)
    ma, mb = ((*base, a), tests[a].theta), ((*base, b), tests[b].theta)
    ca, cb = CANDIDATES[a], CANDIDATES[b]
    return Question("ambiguous", step.step, f"{a} or {b}", (
        Contrast(f"{a} beyond {b}", ma, mb, ca.n_shift, ca.n_spread),
        Contrast(f"{b} beyond {a}", mb, ma, cb.n_shift, cb.n_spread)), level / len(step.candidates))


def _effect_at(final: tuple, effect: str, k: int, size: float, kind: str) -> Contrast:
    """M + ``effect`` with its parameter ``k`` at ``size`` (the others at their null) against M."""
    params = CANDIDATES[effect].parameters
    extra = np.zeros(len(params))
    extra[k] = size / params[k].scale
    return Contrast(f"{effect} {params[k].name} = {format_magnitude(size, params[k].unit, name=params[k].name)}", ((*final[0], effect),
                    np.r_[final[1], extra]), final, int(kind == "shift"), int(kind == "spread"))


def _columns(n: int, quantities: tuple[str, ...]) -> dict[str, int]:
    """Index of each quantity's column in the joint vector (W first); a mast quantity's left mast."""
    cols = model_columns(quantities)
    return {q: n + cols.index(f"{q}_left" if QUANTITIES[q].place == "mast" else q) for q in quantities}


def noncentrality(change, directions, reference, groups, precision=None) -> float:
    """λ of the module docstring.

    Parameters
    ----------
    change : (numpy.ndarray, numpy.ndarray)
        Δ of the joint mean and covariance.
    directions : list of (numpy.ndarray, numpy.ndarray)
        What the null's coordinates (and any shared errors) move the joint moments by, per unit.
    reference : numpy.ndarray
        The null's joint covariance.
    groups : list of (int, numpy.ndarray, numpy.ndarray)
        ``(n_p, columns, noise variances)`` of each group of units carrying the same columns.
    precision : array_like, optional
        Prior precision of each direction (0: free; ``1/s²`` for an error shared with standard
        uncertainty s).
    """
    parts = []
    for count, cols, noise in groups:
        if count <= 0:
            continue
        cov = reference[np.ix_(cols, cols)] + np.diag(noise)
        parts.append((count, cols, np.linalg.inv(cov)))

    def inner(a, b):
        total = 0.0
        for count, cols, inv in parts:
            am, bm = a[0][cols], b[0][cols]
            ac, bc = a[1][np.ix_(cols, cols)], b[1][np.ix_(cols, cols)]
            total += count * (am @ inv @ bm + 0.5 * np.trace(inv @ ac @ inv @ bc))
        return total

    base = inner(change, change)
    if not directions:
        return float(base)
    g = np.array([inner(d, change) for d in directions])
    gram = np.array([[inner(a, b) for b in directions] for a in directions])
    if precision is not None:
        gram = gram + np.diag(np.asarray(precision, dtype=float))
    return float(base - g @ np.linalg.pinv(gram, rcond=1e-10) @ g)


def _groups(option: MeasurementOption, k: int, n_w: int, n: int, column: int, variance: float):
    w = np.arange(n)
    if option.per == "run":
        return [(n_w, np.r_[w, column], np.r_[np.zeros(n), variance])]
    if option.per == "line":
        return [(n_w, w, np.zeros(n)), (1, np.array([column]), np.array([variance]))]
    return [(k, np.r_[w, column], np.r_[np.zeros(n), variance]), (n_w - k, w, np.zeros(n))]


def _existing_groups(obs, n: int, quantities: tuple[str, ...]):
    """The measurements already made as groups of :func:`noncentrality` (spans carrying the same
    columns, each column's mean variance; the line observations one unit each) and their shared
    errors as (direction, prior precision)."""
    if obs is None or obs.empty:
        return [], []
    index = {c: n + i for i, c in enumerate(model_columns(quantities))}
    cols = [index[c] for c in obs.columns]
    measured = np.isfinite(obs.values)
    groups = []
    for key in np.unique(measured, axis=0):
        rows = np.all(measured == key, axis=1)
        variance = np.nanmean(obs.std[rows][:, key] ** 2, axis=0) if key.any() else np.zeros(0)
        groups.append((int(rows.sum()), np.r_[np.arange(n), np.asarray(cols)[key]].astype(int),
                       np.r_[np.zeros(n), variance]))
    for o in obs.line:
        groups.append((1, np.array([index[o.quantity]]), np.array([o.std ** 2])))
    size = n + len(index)
    shared = []
    for c, s in zip(cols, obs.common_std):
        if s > 0:
            e = np.zeros(size)
            e[c] = 1.0
            shared.append(((e, np.zeros((size, size))), 1.0 / s ** 2))
    return groups, shared


def recommend(ctx, qs: list[Question], settings: MeasurementSettings, extent: Extent, power: float,
              workers: int = 1) -> pd.DataFrame:
    """Every option's smallest extent, cost and power for every question, the recommendation
    marked (:data:`RECOMMENDATION_COLUMNS`; module docstring).

    Parameters
    ----------
    ctx : DiagnosisContext
        The diagnosis' models, design and data (its number of spans).
    qs : list of Question
    settings : MeasurementSettings
        Accuracies and options.
    extent : Extent
    power : float
        Power a measurement must reach.
    workers : int
        Processes over the models' moments and over the questions
        (:func:`catenary.plumbing.workers.map_each`): each is its own computation, so the table
        is the same for any number.
    """
    made = ctx.observations
    measured = set() if made is None else {*made.quantities, *(o.quantity for o in made.line)}
    options = [o for o in settings.options if o.quantity in QUANTITIES and o.quantity not in measured]
    quantities = tuple(dict.fromkeys((*(o.quantity for o in settings.options), *sorted(measured))))
    n = ctx.span_type.n_droppers
    n_w = ctx.data.shape[0]
    where = _columns(n, quantities)
    existing, existing_prior = _existing_groups(made, n, quantities)

    def key(model) -> tuple:
        return model[0], np.asarray(model[1]).tobytes()

    def at(model):
        """The joint moments of a model at its coordinates θ, as a function of θ."""
        problem = ctx.problem(tuple(model[0]))

        def moments(theta):
            means, sigmas = problem.laws(theta)
            return problem.likelihood.joint_moments(means, sigmas, problem.magnitudes(theta), quantities)
        return moments, problem.names

    # Every model's moments, then the directions of the nulls a question reads (those of its
    # contrasts up to the first whose truth or null cannot be drawn), each model once.
    models = list({key(m): m for q in qs for c in q.contrasts for m in (c.truth, c.null)}.values())
    found = dict(zip(map(key, models), map_each(lambda k: at(models[k])[0](models[k][1]), len(models), workers, 1)))
    nulls = {}
    for q in qs:
        for c in q.contrasts:
            if found[key(c.truth)] is None or found[key(c.null)] is None:
                break
            nulls.setdefault(key(c.null), c.null)
    nulls = list(nulls.values())

    def directions(model):
        moments, names = at(model)
        return [((up[0] - down[0]) / h, (up[1] - down[1]) / h)
                for up, down, h in moment_steps(moments, np.asarray(model[1], dtype=float), names)]

    directions_of = dict(zip(map(key, nulls), map_each(lambda k: directions(nulls[k]), len(nulls), workers, 1)))

    def rows_of(q: Question) -> list[dict]:
        prepared = []
        for c in q.contrasts:
            truth, null = found[key(c.truth)], found[key(c.null)]
            if truth is None or null is None:
                prepared = None
                break
            prepared.append((c, (truth[0] - null[0], truth[1] - null[1]), directions_of[key(c.null)], null[1]))
        if prepared and existing and min(
                lr_power(noncentrality(change, dirs + [d for d, _ in existing_prior], ref, existing,
                                       np.r_[np.zeros(len(dirs)), [p for _, p in existing_prior]]),
                         c.n_shift, c.n_spread, q.level) for c, change, dirs, ref in prepared) >= power:
            return []                  # what was measured already settles it: the diagnosis' own test answers
        rows = []
        for o in options:
            acc = settings.accuracy[o.quantity]
            col = where[o.quantity]
            shared, prior = [], []
            if acc.common_std > 0:
                e = np.zeros(n + len(model_columns(quantities)))
                e[col] = 1.0
                shared, prior = [(e, np.zeros((e.size, e.size)))], [1.0 / acc.common_std ** 2]
            available = extent.available(o.per)

            def power_at(k):
                if prepared is None:
                    return float("nan")
                return min(lr_power(noncentrality(change, dirs + shared, ref,
                                                  _groups(o, k, n_w, n, col, acc.std ** 2),
                                                  np.r_[np.zeros(len(dirs)), prior]),
                                    c.n_shift, c.n_spread, q.level) for c, change, dirs, ref in prepared)

            full = power_at(available)
            k = available
            if np.isfinite(full) and full >= power and available > 1:
                lo, hi = 0, available                  # power(lo) < target ≤ power(hi)
                while hi - lo > 1:
                    mid = (lo + hi) // 2
                    if power_at(mid) >= power:
                        hi = mid
                    else:
                        lo = mid
                k = hi
            p_k = power_at(k) if k != available else full
            rows.append({"question": q.asked, "kind": q.kind, "step": q.step, "asked": " and ".join(
                c.label for c in q.contrasts), "option": o.name, "quantity": o.quantity, "per": o.per, "extent": k,
                "available": available, "cost_h": float(o.cost_h * (1 if o.per in ("run", "line") else k)),
                "power": p_k, "power_full": full, "enough": bool(np.isfinite(full) and full >= power)})
        return rows

    rows = [row for part in map_each(lambda k: rows_of(qs[k]), len(qs), workers, 1) for row in part]
    table = pd.DataFrame(rows, columns=[c for c in RECOMMENDATION_COLUMNS if c != "recommended"])
    table["recommended"] = False
    for _, part in table.groupby("question", sort=False):
        enough = part[part["enough"]]
        best = (enough.sort_values(["cost_h", "power"], ascending=[True, False]) if len(enough)
                else part.sort_values("power_full", ascending=False)).index[:1]
        table.loc[best, "recommended"] = True
    return table
