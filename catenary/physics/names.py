"""How an engineer names the model's quantities and reads their values: the one place for it.

The files a program reads keep SI and names such as ``dropper_3_length_m``; what a person reads
(the report's front page and tables, the Markdown summaries) says "dropper 3 length" in mm,
"messenger tension T_MW" in N. Light on purpose (no NumPy): the report's tables use it in every
rule that writes one.
"""

from __future__ import annotations

__all__ = ["CRITERION_LABELS", "engineer_input"]

#: How an engineer names each input and reads its values: label, factor from SI, unit.
_ENGINEER = {"dropper_lengths_m": ("dropper lengths", 1e3, "mm"),
             "messenger_tension_n": ("messenger tension T_MW", 1.0, "N"),
             "contact_tension_n": ("contact tension T_CW", 1.0, "N"),
             "system_height_m": ("system height ΔH", 1e3, "mm")}

#: How an engineer names each contact-force criterion of a run (EN 50317/50318/50367), the factor
#: from its SI value and the unit read.
CRITERION_LABELS = {"mean_force_n": ("mean force F_m", 1.0, "N"),
                    "std_force_n": ("standard deviation σ_F", 1.0, "N"),
                    "statistical_max_n": ("statistical maximum F_m + 3σ_F", 1.0, "N"),
                    "statistical_min_n": ("statistical minimum F_m − 3σ_F", 1.0, "N"),
                    "max_force_n": ("largest force", 1.0, "N"),
                    "min_force_n": ("smallest force", 1.0, "N"),
                    "max_support_uplift_m": ("steady-arm uplift", 1e3, "mm"),
                    "contact_loss_percent": ("contact loss", 1.0, "%")}


def engineer_input(parameter: str) -> tuple[str, float, str]:
    """An input's name as an engineer says it, the factor from its SI value and the unit read
    (``dropper_3_length_m`` → "dropper 3 length", 1000, "mm"; ``dropper_3_force_n`` → "dropper 3
    force", 1, "N"); an unknown name stays as it is, in SI."""
    if parameter.startswith("dropper_") and parameter.endswith("_length_m"):
        return f"dropper {parameter.split('_')[1]} length", 1e3, "mm"
    if parameter.startswith("dropper_") and parameter.endswith("_force_n"):
        return f"dropper {parameter.split('_')[1]} force", 1.0, "N"
    return _ENGINEER.get(parameter, (parameter, 1.0, "SI"))
