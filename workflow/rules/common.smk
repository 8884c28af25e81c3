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
