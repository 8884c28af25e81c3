"""Inconsistent catenary configs are refused with a message naming the key."""

import copy

import pytest
import yaml

from catenary.physics.config import catenary_from_dict, load_catenary
from catenary.plumbing.errors import ConfigError

from .conftest import ROOT


@pytest.fixture
def raw():
    return yaml.safe_load((ROOT / "config" / "catenary.yaml").read_text())


@pytest.mark.parametrize("mutate, key", [
    (lambda r: r["span_types"]["N2"].__setitem__("dropper_positions_m", [4.5, 11.25, 60.0]),
     "span_types.N2.dropper_positions_m"),
    (lambda r: r["span_types"]["N2"].__setitem__("dropper_positions_m", [11.25, 4.5, 18.0]),
     "span_types.N2.dropper_positions_m"),
    (lambda r: r["span_types"]["N3"].__setitem__("messenger_tension_n", 0.0), "span_types.N3.messenger_tension_n"),
    (lambda r: r["span_types"]["N3"].__setitem__("contact_tension_n", -25500.0), "span_types.N3.contact_tension_n"),
    (lambda r: r["wires"]["contact"].__setitem__("mass_per_length_kg_m", 0.0), "wires.contact.mass_per_length_kg_m"),
    (lambda r: r["droppers"].__setitem__("axial_stiffness_n", -1.0), "droppers.axial_stiffness_n"),
    (lambda r: r["wires"]["messenger"].pop("bending_stiffness_n_m2"), "wires.messenger.bending_stiffness_n_m2"),
    (lambda r: r["span_types"]["N2"].__setitem__("length_m", "58.5 m"), "span_types.N2.length_m"),
])
def test_inconsistent_config_names_the_key(raw, mutate, key):
    bad = copy.deepcopy(raw)
    mutate(bad)
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")):
        catenary_from_dict(bad)


def test_unknown_span_type_lists_known_ones(catenary):
    with pytest.raises(ConfigError, match="unknown span type 'N9'.*N2, N3"):
        catenary.span_type("N9")


def test_missing_file_is_named(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        load_catenary(tmp_path / "nope.yaml")


def test_the_line_of_make_bench_line_is_a_thousand_spans_of_both_types(catenary):
    # The truth and overlay of `make bench-line` are read as the workflow reads them: the truth
    # through its own checks, the overlay merged into the default config against the schema.
    from snakemake.utils import update_config

    from catenary.plumbing.schema import check
    from catenary.measurement.truth import load_truth

    spec = load_truth(ROOT / "config" / "line" / "line_1000_campaign.yaml", catenary)
    spans = {t: sum(s.n_spans for s in spec.sections if s.span_type == t) for t in ("N2", "N3")}
    assert len(spec.sections) == 50 and spans == {"N2": 500, "N3": 500}
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    overlay = yaml.safe_load((ROOT / "config" / "line" / "line_1000.yaml").read_text())
    merged = copy.deepcopy(config)
    update_config(merged, overlay)              # Snakemake's own merge of --configfile overlays
    check(merged, "config")
    assert "messenger_tension_n" in merged["diagnosis"]["start"]["random_inputs"]
