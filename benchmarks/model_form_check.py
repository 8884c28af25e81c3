"""Remaining systematic differences between the campaign's line and the identification model.

Not run by ``make bench`` (``make validate`` runs it). For every span of a campaign's truth
(default ``config/campaign.yaml``, drawn again here with its seed; optional argument: another
truth file), W is computed under a chain of models:

* ``model``: the identification model — the fast model of the span in the line
  (``neighbours: 1``) with the span's own true dropper lengths, T_MW and ΔH at its two masts;
* ``fe_nominal``: the same span solved by the FE model as the central span of three, the
  neighbours at the nominal table, the span's T_MW and the design ΔH at the outer masts, the
  neighbours' outer steady arms on the line of the span's own chord (a rigid rotation of the
  nominal line; checks that the two agree);
* one FE variant per difference, each switched on alone from ``fe_nominal``:
  ``neighbour_droppers`` (the neighbours' true dropper lengths), ``neighbour_tension`` (their
  true T_MW, drawn per span by the campaign), ``outer_system_height`` (the true ΔH at the
  neighbours' outer masts), ``steady_arm_heights`` (the true CW heights at the four steady
  arms), ``section_end`` (the first and last span of a section have one neighbour only: the
  wires are anchored at the section's end mast);
* ``fe_all``: all of them (the span's true neighbourhood) and ``truth``: the whole section
  solved at once, as the campaign does (checks that one neighbour each side suffices).

For each difference: the mean over spans of ΔW at each dropper (its largest absolute value) and
the RMS over spans and droppers. Then its effect on the identified laws: the identification
(config defaults, N = 1e4) on ``model`` W, and on ``model`` W plus that one difference alone,
and on the truth's static W (all differences); z-shifts are in units of the observed-information
standard error (spans independent: a shift of the estimate, not an interval).
Spans where the fast model finds a slack dropper are left out of every data set (counted).

Writes ``results/model_form_check.json`` and prints two tables.
"""

from record import ROOT  # noqa: I001  (sets one BLAS thread first)

import json
import sys
from pathlib import Path

import numpy as np

from catenary.measurement.campaign import section_model, static_truth
from catenary.measurement.truth import draw_line, load_truth
from catenary.physics.config import load_catenary
from catenary.physics.dropper_table import nominal_dropper_lengths
from catenary.physics.fast import FastSpanModel
from catenary.physics.section import Section
from catenary.physics.static import solve_static
from catenary.stages.identification.runner import run_identification
from catenary.stages.identification.settings import IdentificationSettings

DIFFERENCES = ("neighbour_droppers", "neighbour_tension", "outer_system_height", "steady_arm_heights",
               "section_end")


def neighbourhood(section: Section, j: int, nominal_lengths: np.ndarray, design_dh: float,
                  switched: set[str]) -> tuple[Section, int]:
    """Span ``j`` of ``section`` with one neighbour each side; differences in ``switched`` true.

    Returns the small section and the index of span ``j`` in it.
    """
    n = nominal_lengths.size
    end = "section_end" in switched
    spans = [s for s in (j - 1, j, j + 1) if 0 <= s < section.n_spans] if end else [j - 1, j, j + 1]
    centre = spans.index(j)
    lengths, t_mw, t_cw, span_l = [], [], [], []
    for s in spans:
        real = 0 <= s < section.n_spans
        own = s == j
        src = src_span(s, j, section)
        true_droppers = own or ("neighbour_droppers" in switched and real)
        lengths.append(section.dropper_lengths_m[src * n:(src + 1) * n] if true_droppers else nominal_lengths)
        t_mw.append(section.messenger_tension_by_span_n[src if ("neighbour_tension" in switched or own) else j])
        t_cw.append(section.contact_tension_by_span_n[src])
        span_l.append(section.span_lengths_m[src])
    masts = list(range(spans[0], spans[-1] + 2))
    dh, h = [], []
    for m in masts:
        inner = m in (j, j + 1)
        real = 0 <= m <= section.n_spans
        dh.append(section.system_heights_m[m] if inner or ("outer_system_height" in switched and real) else design_dh)
        if "steady_arm_heights" in switched and real or inner:
            h.append(section.cw_support_heights_m[m])
        else:      # the neighbour's outer steady arm on the line of the span's own chord
            h_l, h_r = section.cw_support_heights_m[j], section.cw_support_heights_m[j + 1]
            slope = (h_r - h_l) / section.span_lengths_m[j]
            x = -section.span_lengths_m[src_span(j - 1, j, section)] if m < j else (
                section.span_lengths_m[j] + section.span_lengths_m[src_span(j + 1, j, section)])
            h.append(h_l + slope * x)
    k = len(spans)
    offsets = np.asarray(section.dropper_offset_m).reshape(section.n_spans, n)[j]
    return Section(span_lengths_m=np.array(span_l), dropper_span=np.repeat(np.arange(k), n),
                   dropper_x_m=np.tile(section.dropper_x_m[:n], k), dropper_lengths_m=np.concatenate(lengths),
                   cw_support_heights_m=np.array(h), system_heights_m=np.array(dh),
                   contact_tension_n=np.array(t_cw), messenger_tension_n=np.array(t_mw),
                   dropper_offset_m=np.tile(offsets, k)), centre


def src_span(s: int, j: int, section: Section) -> int:
    """Span ``s`` if the section has it, else span ``j`` (a missing neighbour copies the span)."""
    return s if 0 <= s < section.n_spans else j


def span_w(section: Section, centre: int, catenary) -> np.ndarray:
    w = solve_static(section, catenary).dropper_deflection_m().reshape(section.n_spans, -1)
    return w[centre]


def main(truth_file: Path) -> None:
    catenary = load_catenary(ROOT / "config" / "catenary.yaml")
    spec = load_truth(truth_file, catenary)
    line = draw_line(spec, catenary)
    truth = static_truth(line, catenary)
    out = {"truth_file": str(truth_file), "span_types": {}}
    for name in sorted(truth["span_type"].unique()):
        st = catenary.span_type(name)
        n = st.n_droppers
        nominal = nominal_dropper_lengths(st, catenary).dropper_lengths_m
        fast = FastSpanModel(st, catenary, messenger_tension_bounds_n=(0.5 * st.messenger_tension_n,
                                                                       1.5 * st.messenger_tension_n),
                             degree=14, neighbours=1)
        rows = {key: [] for key in ("model", "fe_nominal", *DIFFERENCES, "fe_all", "truth")}
        slack = 0
        for k in range(len(line.sections)):
            section, spans = section_model(line, k, catenary)
            if line.spans["span_type"][spans[0]] != name:
                continue
            sec_truth = truth[truth["section_id"] == line.spans["section_id"][spans[0]]]
            for j in range(section.n_spans):
                lengths = section.dropper_lengths_m[j * n:(j + 1) * n]
                res = fast.evaluate(lengths[None], np.array([section.messenger_tension_by_span_n[j]]),
                                    np.array([section.system_heights_m[j]]),
                                    np.array([section.system_heights_m[j + 1]]))
                if res.slack[0]:
                    slack += 1
                    continue
                rows["model"].append(res.w_m[0])
                rows["truth"].append(sec_truth[[f"static_w{i + 1}_m" for i in range(n)]].to_numpy()[j])
                rows["fe_nominal"].append(span_w(*neighbourhood(section, j, nominal, st.system_height_m, set()),
                                                 catenary))
                for d in DIFFERENCES:
                    rows[d].append(span_w(*neighbourhood(section, j, nominal, st.system_height_m, {d}), catenary))
                rows["fe_all"].append(span_w(*neighbourhood(section, j, nominal, st.system_height_m,
                                                            set(DIFFERENCES)), catenary))
        w = {key: np.array(v) for key, v in rows.items()}
        base = w["fe_nominal"]
        on_w = {}
        checks = {"fe_nominal_minus_model_max_m": float(np.abs(base - w["model"]).max()),
                  "fe_all_minus_truth_max_m": float(np.abs(w["fe_all"] - w["truth"]).max()),
                  "sum_of_differences_minus_all_max_m": float(np.abs(
                      sum(w[d] - base for d in DIFFERENCES) - (w["fe_all"] - base)).max())}
        for d in (*DIFFERENCES, "fe_all"):
            delta = w[d] - base
            on_w[d] = {"mean_max_abs_mm": 1e3 * float(np.abs(delta.mean(axis=0)).max()),
                       "mean_mm": (1e3 * delta.mean(axis=0)).round(4).tolist(),
                       "rms_mm": 1e3 * float(np.sqrt(np.mean(delta**2))),
                       "max_abs_mm": 1e3 * float(np.abs(delta).max())}
        # Effect on the identified laws (N = 1e4, config defaults).
        settings = IdentificationSettings.from_mapping(
            {"estimators_n_samples": [1000], "band": {"n_samples": 500, "n_points": 31},
             "normality": {"n_samples": 200}, "profile_intervals": {"parameters": []},
             "standard_errors": "observed_information"})
        data_sets = {"model": w["model"], **{d: w["model"] + (w[d] - base) for d in DIFFERENCES},
                     "truth_static": w["truth"]}
        identified = {}
        for key, data in data_sets.items():
            r = run_identification(st, catenary, data, settings).result
            e = {x.parameter: x for x in r.estimates}
            identified[key] = {f"{p}_{s}": (getattr(e[p], s), getattr(e[p], f"{s}_se"))
                               for p in ("messenger_tension_n", "system_height_m") for s in ("mu", "sigma")}
            identified[key]["status"] = r.status
        ref = dict(identified["model"])
        quantities = [q for q in ref if q != "status"]
        for v in identified.values():
            v["z_shift"] = {q: (v[q][0] - ref[q][0]) / ref[q][1] for q in quantities}
        out["span_types"][name] = {"n_spans": int(base.shape[0]), "slack_spans_left_out": slack,
                                   "checks": checks, "on_w": on_w, "identified": identified}
        print(f"\n{name}: {base.shape[0]} spans ({slack} with a slack dropper left out); "
              f"FE nominal vs model {1e6 * checks['fe_nominal_minus_model_max_m']:.3f} µm, "
              f"three-span vs whole section {1e6 * checks['fe_all_minus_truth_max_m']:.3f} µm, "
              f"non-additivity {1e6 * checks['sum_of_differences_minus_all_max_m']:.3f} µm")
        print("| difference | largest mean ΔW [mm] | RMS ΔW [mm] | largest ΔW [mm] | z-shift T_MW μ | T_MW σ | ΔH μ | ΔH σ |")
        for d in (*DIFFERENCES, "fe_all"):
            key = "truth_static" if d == "fe_all" else d
            z = identified[key]["z_shift"]
            print(f"| {d} | {on_w[d]['mean_max_abs_mm']:.3f} | {on_w[d]['rms_mm']:.3f} | {on_w[d]['max_abs_mm']:.3f} | "
                  f"{z['messenger_tension_n_mu']:+.2f} | {z['messenger_tension_n_sigma']:+.2f} | "
                  f"{z['system_height_m_mu']:+.2f} | {z['system_height_m_sigma']:+.2f} |", flush=True)
    path = ROOT / "results" / "model_form_check.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=2) + "\n")
    print(f"written {path}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "config" / "campaign.yaml")
