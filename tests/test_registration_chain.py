"""The chain of spans found in a height trace without a table (catenary.measurement.registration.chain), on
kink signals built by hand: droppers' kinks where a known line puts them, the sag's peak at its
supports, noise."""

import numpy as np
import pytest

from catenary.measurement.registration.chain import chain_supports, odometer_scale

STEP_M = 0.05
LAG_M = 0.3


def _signals(catenary, supports, kinds, seed: int, kink: float = 2e-3, noise: float = 1e-3):
    """Comb and sag signals of a line with these supports and span types (droppers' kinks
    ``kink`` wide 0.5 m, seen ``LAG_M`` late; the sag's peak at each support; white noise)."""
    rng = np.random.default_rng(seed)
    grid = np.arange(supports[0] - 3.0, supports[-1] + 3.0, STEP_M)
    comb = rng.normal(0.0, noise, grid.size)
    sag = rng.normal(0.0, noise, grid.size)
    for a, b, kind in zip(supports[:-1], supports[1:], kinds):
        st = catenary.span_type(kind)
        for d in st.dropper_positions_m:
            comb += kink * np.exp(-0.5 * ((grid - (a + d * (b - a) / st.length_m + LAG_M)) / 0.25) ** 2)
    for x in supports:
        sag += kink * np.exp(-0.5 * ((grid - x - LAG_M) / 2.0) ** 2)
    return grid, comb, sag


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_section_of_one_type_is_found_whole_at_its_odometer_scale(catenary, seed):
    # 20 N2 spans read 0.3 % long, each mast moved by up to ±0.1 m, the noise half the kinks:
    # every span N2 though N3's 54 m spans are offered too, the scale to 0.05 %, and every
    # support within 0.5 m — the chain only guides the registration, whose fine fit then looks
    # within ± search_m (1.5 m) of it (measured 0.35–0.45 m here; 0.50 / 0.73 m on r_table).
    rng = np.random.default_rng(10 + seed)
    kinds = ["N2"] * 20
    supports = 12.0 + 1.003 * 58.5 * np.arange(21) + rng.uniform(-0.1, 0.1, 21)
    grid, comb, sag = _signals(catenary, supports, kinds, seed)
    found, types = chain_supports(grid, comb, sag, grid[0], grid[-1], catenary, ["N3", "N2"],
                                  {"N2": LAG_M, "N3": LAG_M}, 0.01)
    assert types == kinds
    assert np.max(np.abs(np.asarray(found) - supports)) < 0.5
    assert odometer_scale([(found, types)], catenary) == pytest.approx(1.003, abs=5e-4)


def test_a_change_of_span_type_the_trace_insists_on_is_kept(catenary):
    # 8 N2 spans then 8 N3: the chain pays for one change of type and finds both halves, every
    # support within 0.5 m (as above).
    kinds = ["N2"] * 8 + ["N3"] * 8
    lengths = np.array([58.5 if k == "N2" else 54.0 for k in kinds])
    supports = 5.0 + np.r_[0.0, np.cumsum(lengths)]
    grid, comb, sag = _signals(catenary, supports, kinds, seed=4)
    found, types = chain_supports(grid, comb, sag, grid[0], grid[-1], catenary, ["N3", "N2"],
                                  {"N2": LAG_M, "N3": LAG_M}, 0.01)
    assert types == kinds
    assert np.max(np.abs(np.asarray(found) - supports)) < 0.5


def test_odometer_scale_is_the_slope_of_the_supports_against_the_design():
    # exact on supports at a constant scale, each chain with its own origin
    from catenary.physics.config import load_catenary
    from .conftest import ROOT

    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    a = ([100.0 + 1.002 * x for x in (0.0, 58.5, 117.0)], ["N2", "N2"])
    b = ([5000.0 + 1.002 * x for x in (0.0, 54.0, 112.5)], ["N3", "N2"])
    assert odometer_scale([a, b], catenary) == pytest.approx(1.002, rel=1e-12)
    assert odometer_scale([([1.0], [])], catenary) == 1.0
