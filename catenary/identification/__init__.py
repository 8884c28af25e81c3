"""Statistical identification of the random inputs of a span type (SPEC §6, paper §3).

* :mod:`.design` — random inputs, their Gamma laws and the unit-cube design drawn once;
* :mod:`.likelihood` — J(s) = Σ_k ln p_W(W_k; s) with a Gaussian or kernel estimate of p_W;
* :mod:`.fit` — maximisation of J (Nelder–Mead or BOBYQA) and standard errors;
* :mod:`.synthetic` — synthetic measured deflections from known laws.
"""

from .design import (MESSENGER_TENSION, SYSTEM_HEIGHT, RandomInput, SpanInputs, UnitDesign,
                     default_inputs, design_dimension, draw_unit_design, dropper_names,
                     gamma_quantiles, map_inputs)
from .likelihood import Likelihood, LikelihoodValue, fit_gaussian, gaussian_log_density, kernel_log_density
from .synthetic import simulate_deflections

__all__ = [
    "MESSENGER_TENSION", "SYSTEM_HEIGHT", "Likelihood", "LikelihoodValue", "RandomInput",
    "SpanInputs", "UnitDesign", "default_inputs", "design_dimension", "draw_unit_design",
    "dropper_names", "fit_gaussian", "gamma_quantiles", "gaussian_log_density",
    "kernel_log_density", "map_inputs", "simulate_deflections",
]
