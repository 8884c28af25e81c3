"""Statistical identification of the random inputs of a span type (paper §3).

* :mod:`.design` — random inputs, their Gamma laws and the unit-cube design drawn once;
* :mod:`.likelihood` — J(s) = Σ_k ln p_W(W_k; s) with a Gaussian or kernel estimate of p_W;
* :mod:`.fit` — maximisation of J (Nelder–Mead or BOBYQA) and standard errors;
* :mod:`.scoring` — Fisher scoring of J from a warm start (profile points, the diagnosis's refits);
* :mod:`.profile` — profile-likelihood intervals, and "no spread detected";
* :mod:`.result` — the s_opt table, the J trace and confidence intervals;
* :mod:`.synthetic` — synthetic measured deflections from known laws;
* :mod:`.settings` — the ``identification`` block of the workflow config;
* :mod:`.band` — the CW deflection along the span and its band under given laws (Fig. 10);
* :mod:`.data` — the measured input: the corrected W of a span type, runs averaged;
* :mod:`.runner` — one span type's run (J, s_opt, normality, estimators, band);
* :mod:`.tables` — ``s_opt.csv`` and the optimiser's trace as tables;
* :mod:`.report` — the run in Markdown (``identification.md``);
* :mod:`.figures`, :mod:`.outputs` — the rule's figures and files.

Typical use::

    start = default_inputs(span_type, catenary)
    lik = make_likelihood(span_type, catenary, measured_w_m, start=start, n_samples=10_000, seed=0)
    result = identify(lik, start)            # result.table_rows(), result.trace_rows()
"""

from .design import (MESSENGER_TENSION, SYSTEM_HEIGHT, RandomInput, SpanInputs, UnitDesign,
                     default_inputs, design_dimension, draw_unit_design, dropper_names,
                     gamma_quantiles, map_inputs)
from .fit import ParameterBox, identify, make_likelihood, messenger_tension_bounds_n, observed_information
from .likelihood import (GaussianFit, Likelihood, LikelihoodValue, ModelSample, fit_gaussian,
                         gaussian_log_density, kernel_bandwidth, kernel_log_density)
from .result import IdentificationResult, ParameterEstimate
from .synthetic import simulate_deflections

__all__ = [
    "MESSENGER_TENSION", "SYSTEM_HEIGHT", "GaussianFit", "IdentificationResult", "Likelihood",
    "LikelihoodValue", "ModelSample", "ParameterBox", "ParameterEstimate", "RandomInput",
    "SpanInputs", "UnitDesign", "default_inputs", "design_dimension", "draw_unit_design",
    "dropper_names", "fit_gaussian", "gamma_quantiles", "gaussian_log_density", "identify",
    "kernel_bandwidth", "kernel_log_density", "make_likelihood", "map_inputs",
    "messenger_tension_bounds_n", "observed_information", "simulate_deflections",
]
