import os

import yaml

from catenary.plumbing.schema import check as check_schema, merged_mapping
from catenary.measurement.shipped import FILES as SHIPPED_FILES, MANIFEST as SHIPPED_MANIFEST, SOURCES as SHIPPED_SOURCES
from catenary.measurement.shipped import matches as shipped_campaign_matches

RESULTS = config["results"]
SPAN_TYPES = config["span_types"]
RECORDING_FILES = config["recording"] if isinstance(config["recording"], list) else [config["recording"]]
# A run on the virtual campaign's own recording: the validation rules compare with its truth.
CAMPAIGN_RUN = any(str(path).startswith(f"{RESULTS}/campaign/") for path in RECORDING_FILES)
# The crews' survey (docs/input_formats.md): a file, none, or `campaign` — the survey a virtual
# campaign writes beside its recording (…/campaign/survey.csv) when the recording is a campaign's,
# none beside a user's recording.
_SURVEY = config.get("survey")
SURVEY_FILES = (sorted({os.path.join(os.path.dirname(str(p)), "survey.csv") for p in RECORDING_FILES
                        if os.path.basename(os.path.dirname(str(p))) == "campaign"})[:1]
                if _SURVEY == "campaign" else [_SURVEY] if _SURVEY else [])
# The campaign's outputs shipped for these very files (data/default_campaign for make run) are
# copied, not simulated, while the copy's manifest matches them (catenary.measurement.shipped).
CAMPAIGN_COPY = config.get("campaign_copy")
CAMPAIGN_COPIED, CAMPAIGN_COPY_WHY = shipped_campaign_matches(
    CAMPAIGN_COPY, {key: config[key] for key in SHIPPED_SOURCES}
)


def _load_catenary_config():
    with open(config["catenary"]) as f:
        raw = yaml.safe_load(f)
    check_schema(raw, "catenary", where=config["catenary"])
    unknown = sorted(set(SPAN_TYPES) - set(raw["span_types"]))
    if unknown:
        raise ValueError(
            f"config span_types: {unknown} not defined in {config['catenary']} "
            f"(defined: {sorted(raw['span_types'])})"
        )
    return raw


CATENARY = _load_catenary_config()


def _per_span_type_settings():
    """{block: {span type: settings}} for the blocks that `per_span_type` may override; each
    merged block is checked against the same schema as the global one."""
    from catenary.plumbing.errors import ConfigError

    overrides = config.get("per_span_type") or {}
    unknown = sorted(set(overrides) - set(SPAN_TYPES))
    if unknown:
        raise WorkflowError(f"invalid configuration: per_span_type names {unknown}, not in span_types {SPAN_TYPES}")
    blocks = {}
    for block in ("identification", "diagnosis", "contact_force"):
        blocks[block] = {}
        for span_type in SPAN_TYPES:
            override = overrides.get(span_type, {}).get(block)
            blocks[block][span_type] = merged = merged_mapping(config[block], override)
            if override:                  # the global block itself was checked in the Snakefile
                try:
                    check_schema(merged, "config", block, where=f"per_span_type.{span_type}.{block}")
                except ConfigError as error:
                    raise WorkflowError(f"invalid configuration: {error}") from None
    return blocks


SPAN_TYPE_SETTINGS = _per_span_type_settings()


def span_type_settings(block):
    """A `params` function: the `block` settings of the job's span type (global block + overrides)."""
    return lambda wildcards: SPAN_TYPE_SETTINGS[block][wildcards.span_type]


# The HTML report (make run ends with `snakemake --report results/report.html`): every final table
# and figure is flagged with reported(), filed under its span type (or the whole line, or the
# campaign's validation) and its stage, with a caption from workflow/report/.
PAPER = "1 Paper reproduction (Figs 2–4, 6, dynamics)"
PROJECTION = "2 Projection"
CORRECTION = "3 Dynamic correction"
INVERSION = "4 Dropper-only inversion (Table 1, Fig. 8)"
IDENTIFICATION = "5 Identification (Table 2, Figs 7, 10)"
DIAGNOSIS = "6 Diagnosis"
CONTACT_FORCE = "7 Contact force"
LINE = "Whole recording"
VALIDATION = "Validation against the campaign's truth"


def reported(path, caption, stage, title, category="{span_type}"):
    """A figure at ``path`` flagged for the report, captioned by workflow/report/``caption``.rst
    and filed under ``category`` (by default the job's span type) and ``stage``. (A table: table().)"""
    if path.endswith(".csv"):
        raise ValueError(f"{path}: a table goes to the report through table(), in an engineer's units")
    return report(path, caption=f"../report/{caption}.rst", category=category, subcategory=stage,
                  labels={"result": title, "file": os.path.basename(path)})


def report_table(path):
    """Where the report's copy of the machine table ``path`` lies (under report/tables/)."""
    return f"{RESULTS}/report/tables/{os.path.relpath(path, RESULTS)}"


def table(name, path, caption, stage, title, category="{span_type}"):
    """A rule's table: output ``name`` at ``path``, the machine file (SI, ``_m`` / ``_n`` names),
    and ``<name>_shown``, its copy in an engineer's units (report_table()) flagged for the report as
    reported() flags a figure. The rule's script writes both (catenary.report.tables.write_shown);
    use as ``**table(...)`` among a rule's outputs."""
    return {name: path, f"{name}_shown": report(report_table(path), caption=f"../report/{caption}.rst",
                                                 category=category, subcategory=stage,
                                                 labels={"result": title, "file": os.path.basename(path)})}


def later_laws(wildcards):
    """The identified laws the maintenance and contact-force stages read: those of the spans the
    final model explains, or of every span (diagnosis.later_stages_laws)."""
    choice = SPAN_TYPE_SETTINGS["diagnosis"][wildcards.span_type].get("later_stages_laws", "without_unexplained")
    name = "s_opt.csv" if choice == "all_spans" else "s_opt_explained.csv"
    return f"{RESULTS}/{wildcards.span_type}/identification/{name}"


FRONT_PAGE = f"{RESULTS}/report/front_page.rst"
# `make own-data` (target `measurements`) runs no contact-force study: its front page is written
# apart, by rule front_page_measurements, without the study's verdict and what fixing buys.
FRONT_PAGE_MEASUREMENTS = f"{RESULTS}/report/front_page_measurements.rst"


def front_page_inputs(wildcards, contact_force=True):
    """Per measured span type, what the front page reads, keyed <kind>_<type>: s_opt.csv,
    model_error.csv, the diagnosis' findings, spans, sections and recommendations, the
    maintenance list (unless `maintenance.enabled` is false) and, with ``contact_force``, the
    contact-force summary and what fixing buys."""
    maintenance = (config.get("maintenance") or {}).get("enabled", True)
    inputs = {}
    for span_type in measured_span_types():
        inputs[f"s_opt_{span_type}"] = f"{RESULTS}/{span_type}/identification/s_opt.csv"
        inputs[f"model_error_{span_type}"] = f"{RESULTS}/{span_type}/identification/model_error.csv"
        inputs[f"findings_{span_type}"] = f"{RESULTS}/{span_type}/diagnosis/findings.csv"
        inputs[f"spans_{span_type}"] = f"{RESULTS}/{span_type}/diagnosis/spans.csv"
        inputs[f"sections_{span_type}"] = f"{RESULTS}/{span_type}/diagnosis/sections.csv"
        inputs[f"recommendations_{span_type}"] = f"{RESULTS}/{span_type}/diagnosis/recommendations.csv"
        if maintenance:
            inputs[f"maintenance_{span_type}"] = f"{RESULTS}/{span_type}/maintenance/maintenance.csv"
        if contact_force:
            inputs[f"contact_force_{span_type}"] = f"{RESULTS}/{span_type}/contact_force/summary.csv"
            if maintenance:
                inputs[f"repair_{span_type}"] = f"{RESULTS}/{span_type}/maintenance/repair_summary.csv"
    return inputs


def front_page_limits(wildcards):
    """Per measured span type, its `contact_force` settings (the EN 50367 limits the front page
    states)."""
    return {t: SPAN_TYPE_SETTINGS["contact_force"][t] for t in measured_span_types()}


def _campaign_sections():
    with open(config["campaign"]) as f:
        raw = yaml.safe_load(f)
    check_schema(raw, "campaign", where=config["campaign"])
    return [s["section_id"] for s in raw["line"]["sections"]]


CAMPAIGN_SECTIONS = _campaign_sections()

wildcard_constraints:
    span_type="|".join(SPAN_TYPES),
    section="|".join(CAMPAIGN_SECTIONS),


def static_outputs():
    return expand(
        [
            f"{RESULTS}/{{span_type}}/nominal/dropper_table.csv",
            f"{RESULTS}/{{span_type}}/sensitivity/summary.csv",
            f"{RESULTS}/{{span_type}}/dynamics/statistics.csv",
        ],
        span_type=SPAN_TYPES,
    )


def measurement_outputs():
    outputs = [f"{RESULTS}/spans_report.csv"]
    if CAMPAIGN_RUN:
        outputs += [f"{RESULTS}/validation/projection_round_trip.csv", f"{RESULTS}/validation/registration_check.csv"]
    return outputs


def identification_outputs(span_types=SPAN_TYPES):
    """Outputs of rule identify (workflow/rules/identification.smk), one folder per span type,
    and the check against the truth on campaign runs."""
    outputs = expand(
        [
            f"{RESULTS}/{{span_type}}/identification/{name}"
            for name in ("s_opt.csv", "trace.parquet", "estimators.png", "normality.json", "band.png",
                         "identification.md", "laws_comparison.csv")
        ] + [f"{RESULTS}/{{span_type}}/repeatability/summary.csv"],
        span_type=span_types,
    )
    if CAMPAIGN_RUN:
        outputs.append(f"{RESULTS}/validation/identification_check.csv")
    return outputs


def inversion_outputs(span_types=SPAN_TYPES):
    """Dropper-only inversion (paper §4.1), rule invert in inversion.smk."""
    return expand(
        [
            f"{RESULTS}/{{span_type}}/inversion/droppers.parquet",
            f"{RESULTS}/{{span_type}}/inversion/table1.csv",
            f"{RESULTS}/{{span_type}}/inversion/pearson.png",
        ],
        span_type=span_types,
    )


def paper_outputs():
    """The paper-reproduction simulations of each configured span type (no recording needed):
    dropper table, sensitivity (Figs 2–4), dynamics at 250/300 km/h, T_MW impact (Fig. 6)."""
    return static_outputs() + expand(
        [
            f"{RESULTS}/{{span_type}}/tension_impact/summary.csv",
            f"{RESULTS}/{{span_type}}/tension_impact/tension_impact.png",
        ],
        span_type=SPAN_TYPES,
    )


def measured_span_types():
    """The span types of `span_types` that the projection found spans of (known once the
    projection checkpoint has run). A type without spans gets no per-type job: no failing
    identification for a type the recording does not hold."""
    import pyarrow.parquet as pq

    outputs = checkpoints.project.get().output.spans
    return [t for t, path in zip(SPAN_TYPES, outputs) if pq.read_metadata(path).num_rows > 0]


def measured_outputs(wildcards=None, contact_force=True):
    """Per-type outputs of the measured span types: inversion, identification, diagnosis and,
    unless ``contact_force`` is false, the contact-force study; with the campaign checks."""
    types = measured_span_types()
    outputs = (inversion_outputs(types) + identification_outputs(types) + diagnosis_outputs(types)
               + maintenance_outputs(types))
    if contact_force:
        outputs += contact_force_outputs(types)
        if (config.get("maintenance") or {}).get("enabled", True):
            outputs += expand(f"{RESULTS}/{{span_type}}/maintenance/repair_summary.csv", span_type=types)
    return outputs + [FRONT_PAGE if contact_force else FRONT_PAGE_MEASUREMENTS]


def correction_sections(wildcards=None):
    """Section ids of the projected spans (known once the projection checkpoint has run)."""
    import pyarrow.parquet as pq

    outputs = checkpoints.project.get().output.spans
    return sorted({s for path in outputs for s in pq.read_table(path, columns=["section_id"]).column(0).to_pylist()})


def model_error_sections():
    """Section ids whose correction also measures the model-error budget (rule correct_section
    corrects each alone and starts it first)."""
    import pandas as pd
    import pyarrow.parquet as pq

    from catenary.stages.model_error.sources import ModelErrorSettings

    outputs = checkpoints.project.get().output.spans
    spans = pd.concat([pq.read_table(path, columns=["section_id"]).to_pandas().assign(span_type=span_type)
                       for span_type, path in zip(SPAN_TYPES, outputs)], ignore_index=True)
    return ModelErrorSettings.from_mapping(config.get("model_error")).measured_sections(spans)


def correction_batches():
    """The correction jobs' batches of sections, ``{name: [section ids]}``
    (:func:`catenary.stages.correction.batches.section_batches`): one section per job on a line
    of up to 100 sections, the model-error sections each alone."""
    from catenary.stages.correction.batches import section_batches

    return section_batches(correction_sections(), model_error_sections(), config.get("sections_per_correction_job"))


def correction_outputs():
    outputs = expand(f"{RESULTS}/{{span_type}}/corrected.parquet", span_type=SPAN_TYPES)
    outputs += [f"{RESULTS}/correction/convergence.csv", f"{RESULTS}/correction/summary.csv"]
    if CAMPAIGN_RUN:
        outputs.append(f"{RESULTS}/validation/correction_check.csv")
    return outputs


def diagnosis_outputs(span_types=SPAN_TYPES):
    """Outputs of rule diagnose (workflow/rules/diagnosis.smk) per span type, and the check
    against the hidden effects on campaign runs."""
    outputs = expand(
        [
            f"{RESULTS}/{{span_type}}/diagnosis/{name}"
            for name in ("findings.csv", "candidates.csv", "steps.json", "residuals.png", "eigenvalues.png",
                         "mahalanobis_qq.png", "score_screen.png", "summary.md", "spans.csv", "sections.csv",
                         "spans.png", "recommendations.csv")
        ],
        span_type=span_types,
    )
    if CAMPAIGN_RUN:
        outputs.append(f"{RESULTS}/validation/diagnosis_check.csv")
    return outputs


def maintenance_outputs(span_types=SPAN_TYPES):
    """Per-span posteriors and the maintenance list (workflow/rules/maintenance.smk) per span
    type, with the check against the truth on campaign runs; none when `maintenance.enabled` is
    false."""
    if not (config.get("maintenance") or {}).get("enabled", True):
        return []
    outputs = expand([f"{RESULTS}/{{span_type}}/maintenance/{name}"
                      for name in ("posterior.parquet", "maintenance.csv", "chainage.png")], span_type=span_types)
    if CAMPAIGN_RUN:
        outputs += [f"{RESULTS}/validation/maintenance_check.csv", f"{RESULTS}/validation/spans_check.csv"]
    return outputs


def contact_force_batches(span_type):
    """Batch files of the contact-force study of one span type (every case, every batch)."""
    from catenary.stages.contact_force.settings import ContactForceSettings, n_batches

    settings = ContactForceSettings.from_mapping(SPAN_TYPE_SETTINGS["contact_force"][span_type])
    n_droppers = len(CATENARY["span_types"][span_type]["dropper_positions_m"])
    return [f"{RESULTS}/{span_type}/contact_force/batches/{case}_{b}.parquet"
            for case in settings.cases() for b in range(n_batches(settings, case, n_droppers))]


def contact_force_outputs(span_types=SPAN_TYPES):
    """Outputs of rule contact_force (workflow/rules/contact_force.smk) per span type."""
    return expand(
        [
            f"{RESULTS}/{{span_type}}/contact_force/{name}"
            for name in ("replicates.parquet", "summary.csv", "nominal.csv", "tolerance.csv", "sensitivity.csv",
                         "histograms.png", "sobol.png", "tolerance.png", "report.md")
        ],
        span_type=span_types,
    )
