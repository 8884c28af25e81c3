"""Effects of one's own: registered from a user's module, planted, fitted span by span ([16])."""

import dataclasses
import textwrap

import numpy as np
import pandas as pd
import pytest

from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.effects import EFFECTS, load_modules
from catenary.physics.section import uniform_section
from catenary.physics.static import StaticModel
from catenary.plumbing.errors import ConfigError
from catenary.stages.diagnosis.profile_check import ProfileNoise, ProfileSettings
from catenary.stages.diagnosis.span_effects import fit_span_effect, span_in_line

from .conftest import ROOT

EXAMPLE = ROOT / "docs" / "examples" / "concentrated_mass.py"


def test_a_users_module_registers_its_effects(tmp_path):
    path = tmp_path / "mine.py"
    path.write_text(textwrap.dedent("""
        from catenary.physics.effects import Effect
        def heavier_clamps(p, z, *, factor):
            p.dropper_lengths_m = p.dropper_lengths_m * (1.0 + 0.0 * factor)
        EFFECTS = [Effect("test_plugin_heavier_clamps", heavier_clamps, None)]
    """))
    assert load_modules([path]) == ("test_plugin_heavier_clamps",)
    assert "test_plugin_heavier_clamps" in EFFECTS
    assert load_modules([path]) == ("test_plugin_heavier_clamps",)          # once only
    clash = tmp_path / "clash.py"
    clash.write_text(path.read_text())
    with pytest.raises(ConfigError, match="known already"):
        load_modules([clash])
    empty = tmp_path / "empty.py"
    empty.write_text("x = 1\n")
    with pytest.raises(ConfigError, match="EFFECTS"):
        load_modules([empty], where="effects_modules")
    with pytest.raises(ConfigError, match="no such file"):
        load_modules([tmp_path / "missing.py"])
    # a plug-in written before the package's layers is told where Effect is now; any other
    # missing module is the user's own error, raised as it is
    old = tmp_path / "old.py"
    old.write_text("from catenary.effects import Effect\nEFFECTS = []\n")
    with pytest.raises(ConfigError, match=r"old.py: imports catenary.effects, .* moved to catenary.physics.effects"):
        load_modules([old], where="effects_modules")
    typo = tmp_path / "typo.py"
    typo.write_text("import numpyy\nEFFECTS = []\n")
    with pytest.raises(ModuleNotFoundError, match="numpyy"):
        load_modules([typo])


def test_a_concentrated_mass_kinks_the_cw_by_its_weight_over_the_tension(catenary, n2):
    # A string of tension T under a point load P turns by P/T where the load hangs: 5 kg on the N2
    # CW (25.5 kN) is 1.92 mrad. The FE CW (Euler–Bernoulli, EI 195 N m²: a bending length of
    # 9 cm, rounded over its 0.5 m elements) is read on straight stretches 1–1.5 m either side;
    # the bay's own weight, which bends the wire there too, is removed by the same reading
    # without the mass. Within 0.5 % (measured 0.1 %). The supports carry the mass's weight.
    nominal = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    section = uniform_section(n2, 3, nominal)
    x0 = n2.length_m + 7.9
    loaded = dataclasses.replace(section, cw_point_mass_x_m=np.array([x0]), cw_point_mass_kg=np.array([5.0]))

    def kink(s) -> float:
        h = StaticModel(s, catenary).solve().cw_height_at(x0 + np.array([-1.5, -1.0, 1.0, 1.5]))
        return (h[3] - h[2]) / 0.5 - (h[1] - h[0]) / 0.5

    expected = 5.0 * catenary.gravity_m_s2 / n2.contact_tension_n
    assert kink(loaded) - kink(section) == pytest.approx(expected, rel=0.005)
    assert (StaticModel(loaded, catenary).total_weight_n() - StaticModel(section, catenary).total_weight_n()
            == pytest.approx(5.0 * catenary.gravity_m_s2, abs=1e-6))   # a difference of two 4 kN sums
    mirrored = loaded.mirrored()
    assert mirrored.cw_point_mass_x_m[0] == pytest.approx(mirrored.mast_chainage_m[-1] - x0)


def test_the_worked_example_recovers_a_clamped_mass(catenary, n2):
    # The docs' example effect, written from the physics alone, fitted to a span whose profile
    # holds a 7 kg mass 2.6 m into a bay (the FE model's static change, 1 mm of white noise every
    # 0.1 m, the model's own freedoms removed as from a corrected residual): it explains the span,
    # its mass is within 3 standard errors of the truth and its position within 0.5 m.
    (name,) = load_modules([EXAMPLE])
    effect = EFFECTS[name]
    x = np.arange(0.0, n2.length_m + 1e-9, 0.1)
    p = _design(n2, catenary)
    base = _profile(n2, catenary, p, x)
    p.add_cw_point_masses(7.1, 7.0)
    change = _profile(n2, catenary, p, x) - base
    rng = np.random.default_rng(7)
    profiles = pd.DataFrame({"span_id": "S", "run_id": "run", "x_m": x, "height_m": change + 1e-3 * rng.standard_normal(x.size),
                             "simulated_height_m": 0.0})
    fit = fit_span_effect(effect, "S", profiles, n2, catenary, ProfileNoise(1e-3, 0.0, 0.1), ProfileSettings(), 0.01)
    mass, mass_se = fit.estimates["mass_kg"]
    position, _ = fit.estimates["x_m"]
    assert fit.explained and fit.p_value < 1e-6
    assert abs(mass - 7.0) < 3 * mass_se and mass_se < 1.5
    assert abs(position - 7.1) < 0.5


def _design(n2, catenary):
    from catenary.physics.effects import SpanParameters
    nominal = nominal_dropper_lengths(n2, catenary).dropper_lengths_m
    return SpanParameters.independent_spans(
        nominal[None, :], [n2.messenger_tension_n], [n2.system_height_m], [n2.system_height_m],
        system_height_mean_m=n2.system_height_m, contact_tension_n=n2.contact_tension_n, measuring_force_n=0.0,
        span_length_m=n2.length_m, dropper_x_m=n2.dropper_positions_m)


def _profile(n2, catenary, p, x):
    return StaticModel(span_in_line(n2, catenary, p), catenary).solve().cw_deflection_at(n2.length_m + x)
