import yaml

RESULTS = config["results"]
SPAN_TYPES = config["span_types"]


def _load_catenary_config():
    with open(config["catenary"]) as f:
        raw = yaml.safe_load(f)
    validate(raw, "../schemas/catenary.schema.yaml")
    unknown = sorted(set(SPAN_TYPES) - set(raw["span_types"]))
    if unknown:
        raise ValueError(
            f"config span_types: {unknown} not defined in {config['catenary']} "
            f"(defined: {sorted(raw['span_types'])})"
        )
    return raw


CATENARY = _load_catenary_config()


def _campaign_sections():
    with open(config["campaign"]) as f:
        raw = yaml.safe_load(f)
    validate(raw, "../schemas/campaign.schema.yaml")
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
    if config["recording"].startswith(f"{RESULTS}/campaign/"):
        outputs.append(f"{RESULTS}/validation/projection_round_trip.csv")
    return outputs


def identification_outputs():
    """Outputs of rule identify (workflow/rules/identification.smk), one folder per span type,
    and the check against the truth on campaign runs."""
    outputs = expand(
        [
            f"{RESULTS}/{{span_type}}/identification/{name}"
            for name in ("s_opt.csv", "trace.parquet", "estimators.png", "normality.json", "band.png",
                         "identification.md")
        ],
        span_type=SPAN_TYPES,
    )
    if config["recording"].startswith(f"{RESULTS}/campaign/"):
        outputs.append(f"{RESULTS}/validation/identification_check.csv")
    return outputs


def inversion_outputs():
    """Dropper-only inversion (paper §4.1) and the T_MW impact check (Fig. 6), rules in inversion.smk."""
    return expand(
        [
            f"{RESULTS}/{{span_type}}/inversion/droppers.parquet",
            f"{RESULTS}/{{span_type}}/inversion/table1.csv",
            f"{RESULTS}/{{span_type}}/inversion/pearson.png",
            f"{RESULTS}/{{span_type}}/tension_impact/summary.csv",
            f"{RESULTS}/{{span_type}}/tension_impact/tension_impact.png",
        ],
        span_type=SPAN_TYPES,
    )


def correction_sections(wildcards=None):
    """Section ids of the projected spans (known once the projection checkpoint has run)."""
    import pyarrow.parquet as pq

    outputs = checkpoints.project.get().output.spans
    return sorted({s for path in outputs for s in pq.read_table(path, columns=["section_id"]).column(0).to_pylist()})


def correction_outputs():
    outputs = expand(f"{RESULTS}/{{span_type}}/corrected.parquet", span_type=SPAN_TYPES)
    outputs += [f"{RESULTS}/correction/convergence.csv", f"{RESULTS}/correction/summary.csv"]
    if config["recording"].startswith(f"{RESULTS}/campaign/"):
        outputs.append(f"{RESULTS}/validation/correction_check.csv")
    return outputs


def diagnosis_outputs():
    """Outputs of rule diagnose (workflow/rules/diagnosis.smk) per span type, and the check
    against the hidden effects on campaign runs."""
    outputs = expand(
        [
            f"{RESULTS}/{{span_type}}/diagnosis/{name}"
            for name in ("findings.csv", "candidates.csv", "steps.json", "residuals.png", "eigenvalues.png",
                         "mahalanobis_qq.png", "score_screen.png", "summary.md")
        ],
        span_type=SPAN_TYPES,
    )
    if config["recording"].startswith(f"{RESULTS}/campaign/"):
        outputs.append(f"{RESULTS}/validation/diagnosis_check.csv")
    return outputs


def contact_force_batches(span_type):
    """Batch files of the contact-force study of one span type (every case, every batch)."""
    from catenary.contact_force.settings import ContactForceSettings, n_batches

    settings = ContactForceSettings.from_mapping(config["contact_force"])
    n_droppers = len(CATENARY["span_types"][span_type]["dropper_positions_m"])
    return [f"{RESULTS}/{span_type}/contact_force/batches/{case}_{b}.parquet"
            for case in settings.cases() for b in range(n_batches(settings, case, n_droppers))]


def contact_force_outputs():
    """Outputs of rule contact_force (workflow/rules/contact_force.smk) per span type."""
    return expand(
        [
            f"{RESULTS}/{{span_type}}/contact_force/{name}"
            for name in ("replicates.parquet", "summary.csv", "nominal.csv", "tolerance.csv", "sensitivity.csv",
                         "histograms.png", "sobol.png", "tolerance.png", "report.md")
        ],
        span_type=SPAN_TYPES,
    )
