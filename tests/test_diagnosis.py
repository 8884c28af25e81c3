"""Discrepancy workflow: candidate physics against the FE model, its statistics against
Monte Carlo and analytic results, and the forward selection on spans of known truth."""

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.effects import EFFECTS
from catenary.physics.measuring import force_influence
from catenary.physics.pantograph import load_pantographs
from catenary.physics.section import uniform_section
from catenary.physics.static import StaticModel, solve_static
from catenary.stages.diagnosis.candidates import CANDIDATES
from catenary.stages.diagnosis.locate import mixture_sf, required_noncentrality, secant_noncentrality
from catenary.stages.diagnosis.model import simulate_spans
from catenary.stages.diagnosis.outputs import DiagnosisPaths, write_diagnosis
from catenary.stages.diagnosis.runner import diagnose, make_sampler
from catenary.stages.diagnosis.settings import DiagnosisSettings
from catenary.stages.identification.settings import IdentificationSettings

from .conftest import ROOT, TABLE2_DROPPER_SIGMA_M, TABLE2_MESSENGER_TENSION_N, TABLE2_SYSTEM_HEIGHT_M

IDENT = IdentificationSettings.from_mapping({})
#: The paper's first model (T_MW not random) at a small design, for the tests.
SETTINGS = DiagnosisSettings.from_mapping({"n_samples": 2000, "max_steps": 2, "bootstrap_replicates": 400})
LARGE = {"messenger_tension_variability": {"std_n": 800.0}, "contact_tension_variability": {"std_n": 600.0},
         "dropper_creep": {"mean_m": 0.004, "std_m": 0.005}, "system_height_dropper_correlation": {"gain": 1.2},
         "cw_longitudinal_offset": {"mean_m": 0.12, "std_m": 0.04}, "steady_arm_height_difference": {"std_m": 0.05},
         "contact_wire_wear": {"mean_fraction": 0.1, "std_fraction": 0.03}}


def _laws(sampler, t_mw_sigma_n=TABLE2_MESSENGER_TENSION_N[0] * 1e-9):
    n = 9
    means = np.r_[nominal_dropper_lengths(sampler.models.span_type, sampler.models.catenary).dropper_lengths_m,
                  TABLE2_MESSENGER_TENSION_N[0], TABLE2_SYSTEM_HEIGHT_M[0]]
    sigmas = np.r_[TABLE2_DROPPER_SIGMA_M, t_mw_sigma_n, TABLE2_SYSTEM_HEIGHT_M[1]]
    assert means.size == n + 2
    return means, sigmas


@pytest.mark.parametrize("effect", [None, *LARGE])
def test_model_span_with_an_effect_is_the_fe_span_in_the_line(catenary, n2, effect):
    # The sampler applies the campaign's effect function to the model spans and evaluates the
    # fast model; here the same spans are built as the central span of three nominal ones and
    # solved by the static FE model (worn CW as a lighter wire, raised steady arms as support
    # heights, inclined droppers as offset clamps). Tolerance: the fast model's Chebyshev
    # interpolation, 1e-6 m in the tensions, 4e-5 m in the clamp offset (measured 3.3e-5 m at
    # degree 6 over ±0.5 m).
    effects = (effect,) if effect else ()
    sampler = make_sampler(n2, catenary, IDENT, SETTINGS, effects)
    z = np.random.default_rng(3).standard_normal((4, sampler.dimension)).clip(-2.5, 2.5)
    means, sigmas = _laws(sampler, t_mw_sigma_n=300.0)
    mags = {effect: LARGE[effect]} if effect else None
    w, f_min = sampler(z, means, sigmas, mags)
    p = sampler.span_parameters(z, means, sigmas, mags)
    nominal = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    for k in range(z.shape[0]):
        lengths = np.r_[nominal, p.dropper_lengths_m[k], nominal]
        section = uniform_section(n2, 3, nominal, contact_tension_n=p.contact_tension_n[k],
                                  messenger_tension_n=p.messenger_tension_n[k])
        heights = section.cw_support_heights_m.copy()
        heights[1] += p.cw_height_offset_left_m[k]
        heights[2] += p.cw_height_offset_right_m[k]
        dh = section.system_heights_m.copy()
        dh[1], dh[2] = p.system_height_left_m[k], p.system_height_right_m[k]
        offsets = np.r_[np.zeros(9), np.full(9, p.cw_offset_m[k]), np.zeros(9)]
        fe_section = type(section)(**{**section.__dict__, "dropper_lengths_m": lengths, "cw_support_heights_m": heights,
                                      "system_heights_m": dh, "dropper_offset_m": offsets,
                                      "cw_mass_factor": np.array([1.0, 1.0 - p.cw_wear_fraction[k], 1.0])})
        sol = solve_static(fe_section, catenary)
        assert not sol.any_slack
        tol = 4e-5 if effect == "cw_longitudinal_offset" else 1e-6
        np.testing.assert_allclose(w[k], sol.dropper_deflection_m()[9:18], atol=tol)
        np.testing.assert_allclose(f_min[k], sol.dropper_force_n[9:18].min(), rtol=1e-4, atol=1e-2)


def test_steady_arm_raise_is_removed_by_the_projection(catenary, n2):
    # Paper Fig. 3: raising the steady arms (MW with them) changes W only through the wires'
    # continuity into the neighbours: ≈ 1.3e-3 of the raise for the span in the line (measured:
    # 0.064 mm for 5 cm), and nothing (up to rounding) for the pinned span.
    for neighbours, bound in ((1, 2e-3), (0, 1e-9)):
        settings = DiagnosisSettings.from_mapping({"n_samples": 500, "start": {"neighbours": neighbours}})
        sampler = make_sampler(n2, catenary, IDENT, settings, ("steady_arm_height_difference",))
        z = np.zeros((1, sampler.dimension))
        z[0, sampler.columns["steady_arm_height_difference"]] = 1.0          # left mast +σ, right 0
        means, sigmas = _laws(sampler)
        w0, _ = sampler(z, means, sigmas, {"steady_arm_height_difference": {"std_m": 0.0}})
        w1, _ = sampler(z, means, sigmas, {"steady_arm_height_difference": {"std_m": 0.05}})
        assert np.abs(w1 - w0).max() < bound * 0.05


def test_force_influence_is_the_static_point_load_response(catenary, n2):
    # Quasi-statically, the measured height at x is the static CW height under the force at x;
    # W is read from the chord through the measured heights at the masts. With steady arms that
    # hold the CW (stiffness null) the force at a mast moves nothing, and the static FE model
    # (which always holds it) is an independent computation: one solve per dropper with ±1 N.
    import dataclasses

    held = dataclasses.replace(catenary, steady_arm=dataclasses.replace(catenary.steady_arm, stiffness_n_m=None))
    pantograph = load_pantographs(ROOT / "config" / "pantographs.yaml")["measuring"].with_static_force(36.0)
    g = force_influence(n2, held, pantograph, speed_m_s=40 / 3.6, mode="quasi_static")
    nominal = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    section = uniform_section(n2, 5, nominal)
    model = StaticModel(section, catenary)
    x = section.mast_chainage_m[2] + n2.dropper_positions_m
    expected = []
    for xi in x:
        up = model.solve(cw_point_loads=(np.array([xi]), np.array([37.0]))).cw_height_at(np.array([xi]))[0]
        down = model.solve(cw_point_loads=(np.array([xi]), np.array([35.0]))).cw_height_at(np.array([xi]))[0]
        expected.append((up - down) / 2.0)
    np.testing.assert_allclose(g, expected, atol=1e-9)
    # With the hinged steady arms of the default data the masts rise too and the chord takes
    # part of the uplift: ≈ 0.17 mm/N mid-span (a 6 N error lifts W by ≈ 1 mm), < 0 at the ends.
    g = force_influence(n2, catenary, pantograph, speed_m_s=40 / 3.6, mode="quasi_static")
    assert 0.1e-3 < g[4] < 0.3e-3 and g[0] < 0 and g[-1] < 0
    # its two passes in two processes: the same influence, bit for bit
    np.testing.assert_array_equal(g, force_influence(n2, catenary, pantograph, speed_m_s=40 / 3.6,
                                                     mode="quasi_static", workers=2))


def test_boundary_mixture_is_the_law_of_a_one_sided_likelihood_ratio():
    # LR of H0: μ = 0 against μ ≥ 0 for one N(μ, 1) observation is max(x, 0)²: the ½χ²₀ + ½χ²₁
    # mixture; with one more free-sign parameter, ½χ²₁ + ½χ²₂. Monte Carlo with 2e5 draws:
    # standard error of a tail probability near 0.05 is 5e-4.
    rng = np.random.default_rng(11)
    x = rng.standard_normal((200_000, 2))
    lr1 = np.maximum(x[:, 0], 0.0) ** 2
    lr2 = lr1 + x[:, 1] ** 2
    for c in (0.5, 2.71, 5.41):
        assert np.mean(lr1 > c) == pytest.approx(mixture_sf(c, 0, 1), abs=3e-3)
        assert np.mean(lr2 > c) == pytest.approx(mixture_sf(c, 1, 1), abs=3e-3)
    assert mixture_sf(0.0, 0, 1) == 1.0 and mixture_sf(3.84, 1, 0) == pytest.approx(0.05, abs=1e-3)


def test_required_noncentrality_gives_the_stated_power():
    rng = np.random.default_rng(12)
    level, power = 0.01 / 8, 0.8
    lam = required_noncentrality("shift", level, power)
    lr = stats.ncx2(1, lam).rvs(200_000, random_state=rng)
    assert np.mean(lr > stats.chi2.isf(level, 1)) == pytest.approx(power, abs=5e-3)
    lam = required_noncentrality("spread", level, power)
    root = np.sqrt(lam) + rng.standard_normal(200_000)              # √LR on the boundary
    assert np.mean(np.maximum(root, 0) ** 2 > stats.norm.isf(level) ** 2) == pytest.approx(power, abs=5e-3)


def test_secant_noncentrality_is_the_fisher_norm_of_what_the_base_cannot_absorb():
    # Gaussian W with Σ fixed and a mean m0 + φ a: λ = ν φ² a⊥ᵀ Σ⁻¹ a⊥, a⊥ the part of a that
    # the base's mean directions B cannot reproduce (projection in the Σ⁻¹ metric).
    rng = np.random.default_rng(5)
    n, nu, phi = 4, 117, 0.3
    q = rng.standard_normal((n, n))
    sigma = q @ q.T + n * np.eye(n)
    a, b = rng.standard_normal(n), rng.standard_normal((2, n))
    base = [(b[i], np.zeros((n, n))) for i in range(2)]
    inv = np.linalg.inv(sigma)
    coef = np.linalg.solve(b @ inv @ b.T, b @ inv @ a)
    a_perp = a - coef @ b
    lam = secant_noncentrality((phi * a, np.zeros((n, n))), base, sigma, nu)
    assert lam == pytest.approx(nu * phi**2 * a_perp @ inv @ a_perp, rel=1e-10)
    # A covariance change: ½ ν tr((Σ⁻¹ ΔΣ)²) with nothing to absorb it.
    ds = 0.1 * np.eye(n)
    assert secant_noncentrality((np.zeros(n), ds), [], sigma, nu) == pytest.approx(
        0.5 * nu * np.trace(inv @ ds @ inv @ ds), rel=1e-10)


def test_every_candidate_is_an_effect_or_a_model_form_and_vanishes_at_its_null(catenary, n2):
    for name, c in CANDIDATES.items():
        assert name in EFFECTS or name == "wire_continuity"
        if name in EFFECTS:
            assert {p.name for p in c.parameters} == set(EFFECTS[name].magnitudes)
    sampler = make_sampler(n2, catenary, IDENT, SETTINGS, tuple(n for n in LARGE))
    z = np.random.default_rng(4).standard_normal((5, sampler.dimension)).clip(-3, 3)
    means, sigmas = _laws(sampler)
    base = make_sampler(n2, catenary, IDENT, SETTINGS, ())
    w_null, _ = sampler(z, means, sigmas, {n: CANDIDATES[n].null() for n in LARGE})
    # Equal up to the Chebyshev interpolation of the richer model in T_CW and the offset (1e-6 m;
    # measured 2e-7 m): at their null the effects change nothing.
    np.testing.assert_allclose(w_null, base(z, means, sigmas, None)[0], atol=1e-6)


@pytest.fixture(scope="module")
def tension_run(catenary, n2, tmp_path_factory):
    # 117 spans of Table 2 laws with an 800 N per-span T_MW spread, as the campaign plants it,
    # through the same sampler (i.i.d. draws) plus 0.6 mm of noise per dropper (the measured
    # correction residual); the diagnosis starts from the paper's first model (T_MW fixed).
    sampler = make_sampler(n2, catenary, IDENT, SETTINGS, ("messenger_tension_variability",))
    means, sigmas = _laws(sampler)
    data = simulate_spans(sampler, means, sigmas, {"messenger_tension_variability": {"std_n": 800.0}}, 117,
                          seed=21, noise_std_m=0.0006)
    run = diagnose(n2, catenary, data, IDENT, SETTINGS, workers=2)
    paths = DiagnosisPaths.in_folder(tmp_path_factory.mktemp("diagnosis"))
    write_diagnosis(run, paths)
    return run, paths


# The two diagnoses of 117 spans below take ≈ 10 min together on 2 cores: `make validate`
# (marker `validation`). Each is one draw of what the replicate tests there check over many
# (tests/test_diagnosis_replicates.py: T_MW σ 600 N named with its size, then nothing; no false
# alarm in 19 of 20 null replicates). `make test-pipeline` checks the same forward selection end to end on
# the small profile (tests/test_pipeline_truth.py: the T_MW spread named, then nothing; the files
# it writes).
@pytest.mark.validation
def test_tension_spread_is_named_with_its_size_and_then_nothing(tension_run):
    run, _ = tension_run
    first = run.steps[0]
    assert first.verdict == "named" and first.effect == "messenger_tension_variability"
    value, se = first.leading.estimates["std_n"]
    assert abs(value - 800.0) < 3 * se                 # 800 N planted (the realized spread differs by ≈ 50 N)
    assert not first.before.top_eigenvalue_inside and first.after.top_eigenvalue_inside
    assert first.after.free_gaussian_gain < 0.3 * first.before.free_gaussian_gain
    assert [s.verdict for s in run.steps] == ["named", "none_detected"]
    assert "steady_arm_height_difference" not in run.named


@pytest.mark.validation
def test_spans_without_a_missing_effect_give_none_detected(catenary, n2):
    sampler = make_sampler(n2, catenary, IDENT, SETTINGS, ())
    means, sigmas = _laws(sampler)
    data = simulate_spans(sampler, means, sigmas, None, 117, seed=22, noise_std_m=0.0006)
    run = diagnose(n2, catenary, data, IDENT, SETTINGS, workers=2)
    assert [s.verdict for s in run.steps] == ["none_detected"]
    assert all(c.p_adjusted >= SETTINGS.level for c in run.steps[0].candidates)


def test_too_few_spans_are_refused_before_any_fit(catenary, n2):
    # the paper's first model has 12 parameters (10 σ, T_MW and ΔH means): 2 spans cannot determine
    # them; the diagnosis refuses as the identification does, naming the spans lost upstream
    from catenary.plumbing.errors import InputError

    sampler = make_sampler(n2, catenary, IDENT, SETTINGS, ())
    means, sigmas = _laws(sampler)
    data = simulate_spans(sampler, means, sigmas, None, 2, seed=3, noise_std_m=0.0006)
    with pytest.raises(InputError, match=r"span type N2: 2 measured span\(s\) \(13 more left out.*for 12 identified"):
        diagnose(n2, catenary, data, IDENT, SETTINGS, n_left_out=13)


def _small_tension_case(catenary, n2, max_evaluations: int, candidates: list[str], n_spans: int, seed: int,
                        optimiser: str = "fisher-scoring"):
    """Settings of a small one-step diagnosis (N = 500) and ``n_spans`` spans with an 800 N
    per-span T_MW spread drawn through its sampler, plus the correction's 0.6 mm residual."""
    settings = DiagnosisSettings.from_mapping({"n_samples": 500, "max_steps": 1, "bootstrap_replicates": 100,
                                               "max_evaluations": max_evaluations, "candidates": candidates,
                                               "optimiser": optimiser})
    sampler = make_sampler(n2, catenary, IDENT, settings, ("messenger_tension_variability",))
    means, sigmas = _laws(sampler)
    data = simulate_spans(sampler, means, sigmas, {"messenger_tension_variability": {"std_n": 800.0}}, n_spans,
                          seed=seed, noise_std_m=0.0006)
    return settings, data


def test_the_sandwich_of_the_verdicts_candidates_gives_the_verdict_of_every_sandwich(monkeypatch):
    # The sandwich (J's Hessian, as costly as a refit) divides a significant candidate's LR by
    # a factor ≥ 1 and leaves its BIC as it is. sandwich_leaders computes it for the leader by BIC
    # among the significant candidates and its runner-up only, the next significant one leading
    # when the leader does not stay significant; the verdict must be the one every significant
    # candidate's sandwich gives. Here the BIC leader loses its significance (factor 40), so the
    # second leads; the third, significant, is never sandwiched (its factor stays NaN).
    import dataclasses
    from types import SimpleNamespace

    from catenary.stages.diagnosis import refits, runner

    level = 0.01
    factors = {"a": 40.0, "b": 1.2, "c": 3.0, "d": 1.0}

    def sandwiched(ctx, problem, fit, new, n_tests, *, sandwich=False, **screen):
        t = new
        if sandwich and t.p_adjusted < level:
            # a factor of 40 takes a's LR below significance; the others stay significant
            p = min(1.0, t.p_adjusted * 1e4) if factors[t.effect] > 10 else t.p_adjusted
            t = dataclasses.replace(t, lr_factor=factors[t.effect], p_adjusted=p)
        return t, new

    def test(effect, bic, p):
        return refits.CandidateTest(effect, 1, 0.0, 0.0, 0.0, float("nan"), p, p, bic, bic, {}, {}, 0.0, 1.0, {},
                                    True, 1, 0.0)

    monkeypatch.setattr(refits, "_tested", sandwiched)
    ctx = SimpleNamespace(settings=SimpleNamespace(level=level), problem=lambda effects: None, workers=1)
    tests = [test("a", -100.0, 1e-3), test("b", -90.0, 1e-4), test("c", -80.0, 1e-5), test("d", -70.0, 0.5)]
    lazy = refits.sandwich_leaders(ctx, (), None, {t.effect: (t, t) for t in tests}, 4)
    every = {t.effect: sandwiched(ctx, None, None, t, 4, sandwich=True)[0] for t in tests}
    assert {e for e, (t, _) in lazy.items() if np.isfinite(t.lr_factor)} == {"a", "b"}  # c ranks third
    verdict = runner._verdict([t for t, _ in lazy.values()], level, 6.0)
    # b leads; a, no longer significant, still has the better BIC: ambiguous between them
    assert verdict == runner._verdict(list(every.values()), level, 6.0) == ("ambiguous", "b", "a")


def test_the_verdict_and_its_figures_do_not_depend_on_the_workers(catenary, n2, tmp_path):
    # The candidates' refits are independent and deterministic: run by one process in config
    # order, or by two that start the costliest (the CW offset's, 3.3× a base evaluation) first
    # and finish in any order, they give the same tests, in config order. Small design (N = 500,
    # 30 spans, 3 candidates, one step) and a budget of 60 evaluations per refit (the two best
    # restarted once): what is compared is the scheduling, not the optimum. With a budget of
    # 300 and 40 spans, both runs took 111 s on 2 cores (it was in `make test-slow`); now 8 s with
    # the recommendation tables (2026-11-28).
    settings, data = _small_tension_case(catenary, n2, 60, ["messenger_tension_variability", "dropper_creep",
                                                            "cw_longitudinal_offset"], n_spans=30, seed=23)
    one, two = (diagnose(n2, catenary, data, IDENT, settings, workers=w) for w in (1, 2))
    assert [c.effect for c in two.steps[0].candidates] == list(settings.candidates)
    for a, b in zip(one.steps[0].candidates, two.steps[0].candidates):
        assert (a.effect, a.delta_loglik, a.p_value, a.n_evaluations) == (b.effect, b.delta_loglik, b.p_value,
                                                                          b.n_evaluations)
    assert (one.steps[0].verdict, one.steps[0].effect) == (two.steps[0].verdict, two.steps[0].effect)
    # What to measure next: each model's moments and each question's options in worker
    # processes give the table of one process, bit for bit.
    from catenary.measurement.channels.settings import MeasurementSettings
    from catenary.stages.diagnosis.recommend import Extent, questions, recommend

    asked = questions(one)
    assert asked
    tables = [recommend(run.context, asked, MeasurementSettings(), Extent(30, 3, 33), 0.8, workers=w)
              for run, w in ((one, 1), (two, 2))]
    pd.testing.assert_frame_equal(*tables, check_exact=True)
    # Its files — four figures and the tables — written by one process or by two side by side:
    # the same bytes.
    folders = [DiagnosisPaths.in_folder(tmp_path / f"workers_{w}") for w in (1, 2)]
    for paths, w in zip(folders, (1, 2)):
        write_diagnosis(two, paths, tables[0], workers=w)
    written = sorted(p.name for p in (tmp_path / "workers_1").iterdir())
    assert {"residuals.png", "findings.csv", "summary.md"} <= set(written)
    assert written == sorted(p.name for p in (tmp_path / "workers_2").iterdir())
    for name in written:
        assert (tmp_path / "workers_1" / name).read_bytes() == (tmp_path / "workers_2" / name).read_bytes(), name


def test_a_leading_refit_that_spent_its_budget_is_restarted_and_only_gains(catenary, n2):
    # The verdict rests on the two best candidates by BIC: a refit of theirs stopped by
    # max_evaluations is restarted once from its best point (its J can only rise, its budget
    # adds up); the others keep their single run. A budget of 60 evaluations stops every
    # Nelder–Mead refit of these 14-coordinate models (it needs hundreds): the two best must show
    # more than 60 evaluations and a Δℓ at least that of their first run, the third exactly 60.
    from catenary.stages.diagnosis import runner, refits

    settings, data = _small_tension_case(catenary, n2, 60, ["messenger_tension_variability", "dropper_creep",
                                                            "contact_tension_variability"], n_spans=30, seed=24,
                                         optimiser="nelder-mead")
    run = diagnose(n2, catenary, data, IDENT, settings)
    ranked = sorted(run.steps[0].candidates, key=lambda c: c.bic)
    base = settings.base(IDENT)
    cands, _ = runner.applicable_candidates(settings, base, n2.n_droppers, False)
    ctx = refits.DiagnosisContext(n2, catenary, data, base, settings, None, 36.0, cands, None)
    base_moments = refits.base_moments_at(ctx, ctx.problem(()), run.start.theta)
    for c in ranked[:2]:
        assert c.n_evaluations > 60
        first = refits.refit_and_test(ctx, (), run.start, base_moments, c.effect, len(cands))[0]
        assert first.n_evaluations == 60 and not first.converged
        assert c.delta_loglik >= first.delta_loglik - 1e-9
    assert ranked[2].n_evaluations == 60


@pytest.fixture(scope="module")
def tension_start(catenary, n2):
    """A small tension case (60 spans, N = 2 000), its context and fitted starting model. The
    scoring needs J smooth at its difference steps: at N = 1 000 it certified the spread's
    refit on one design of this case and not on another; at N = 2 000 and 4 000 on every one
    tried (4 cases, 6–11 iterations)."""
    import dataclasses

    from catenary.stages.diagnosis import refits, runner
    from catenary.stages.diagnosis.problem import refit

    settings, data = _small_tension_case(catenary, n2, 4000, ["messenger_tension_variability"], n_spans=60, seed=26)
    settings = dataclasses.replace(settings, n_samples=2000)
    base = settings.base(IDENT)
    cands, _ = runner.applicable_candidates(settings, base, n2.n_droppers, False)
    ctx = refits.DiagnosisContext(n2, catenary, data, base, settings, None, 36.0, cands, None)
    problem = ctx.problem(())
    start = refit(problem, np.zeros(len(problem.names)), ctx.box, base_step=base.initial_step, max_evaluations=4000)
    assert start.converged
    return settings, ctx, start


def test_candidate_refits_reach_the_maximum_of_a_tight_nelder_mead(tension_start):
    # A candidate's refit: Fisher scoring (catenary.stages.identification.scoring) by default, Nelder–Mead at
    # xtol 0.1 / ftol 0.01 where the scoring cannot certify (DiagnosisSettings). The test needs
    # Δℓ to about 0.1 (critical values ≈ 10, BIC margin 6): on 60 spans with a planted T_MW
    # spread, the scoring must certify the spread's refit — a full step predicted to gain less
    # than ftol — and end within 0.01 of a tight Nelder–Mead (xtol 10⁻⁴, ftol 10⁻⁶: J to
    # ≈ 10⁻⁵) with under a quarter of its evaluations
    # (the model fits these data, so the scoring step is nearly Newton's; measured on the default
    # campaign's N2, 117 spans at N = 10⁴: 162 evaluations against Nelder–Mead's 1 221 at the
    # default tolerances and 1 409 at 10⁻³ / 10⁻⁴, the same J within 10⁻³).
    from catenary.stages.diagnosis.problem import refit

    settings, ctx, start = tension_start
    assert (settings.optimiser, settings.xtol, settings.ftol) == ("fisher-scoring", 0.1, 0.01)
    joint = ctx.problem(("messenger_tension_variability",))
    theta0 = np.r_[start.theta, 0.0]
    tight = refit(joint, theta0, ctx.box, base_step=0.1, max_evaluations=8000, xtol=1e-4, ftol=1e-6)
    scored = refit(joint, theta0, ctx.box, base_step=0.1, max_evaluations=4000, xtol=settings.xtol, ftol=settings.ftol,
                   method=settings.optimiser)
    assert tight.converged and scored.converged
    assert tight.j - start.j > 10.0                               # the planted spread is there to be found
    assert scored.message.startswith("Fisher scoring converged"), scored.message
    assert scored.j == pytest.approx(tight.j, abs=0.01)
    assert scored.n_evaluations < 0.25 * tight.n_evaluations, (scored.n_evaluations, tight.n_evaluations)


def test_a_scoring_that_cannot_certify_its_maximum_hands_over_to_nelder_mead(tension_start, monkeypatch):
    # One scoring iteration cannot certify a maximum tens of units of J away: the refit must go
    # on by Nelder–Mead from the scoring's end (so J can only rise from there), say so in its
    # message, count both runs' evaluations and reach the scoring's own certified maximum
    # within 0.01 (the accuracy the test needs, as above).
    import functools

    from catenary.stages.diagnosis import problem as problem_module
    from catenary.stages.identification.scoring import fisher_scoring

    settings, ctx, start = tension_start
    joint = ctx.problem(("messenger_tension_variability",))
    theta0 = np.r_[start.theta, 0.0]
    full = problem_module.refit(joint, theta0, ctx.box, ftol=settings.ftol, method="fisher-scoring")
    assert full.message.startswith("Fisher scoring converged"), full.message
    one = fisher_scoring(joint, theta0, *joint.bounds(ctx.box), np.r_[np.zeros(joint.n_base, bool), True],
                         ftol=settings.ftol, max_iterations=1)
    assert not one.certified and one.message == "not converged in 1 iterations"
    monkeypatch.setattr(problem_module, "fisher_scoring", functools.partial(fisher_scoring, max_iterations=1))
    handed = problem_module.refit(joint, theta0, ctx.box, base_step=0.1, xtol=settings.xtol, ftol=settings.ftol,
                                  method="fisher-scoring")
    assert handed.message.startswith("Fisher scoring not converged in 1 iterations; Nelder–Mead: ")
    assert handed.converged and handed.n_evaluations > one.n_evaluations
    assert handed.j >= one.j
    assert handed.j == pytest.approx(full.j, abs=0.01)
