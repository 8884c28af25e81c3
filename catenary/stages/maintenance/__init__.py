"""Per-span answers for maintenance (issue [14], the paper's Bayesian step).

* :mod:`.prior` — a span's prior: the identified laws with their uncertainty, the fault
  component, the fast model;
* :mod:`.posterior` — each span's posterior given its corrected W (Laplace proposal, importance
  weights);
* :mod:`.settings` — the ``maintenance`` config block, tolerances;
* :mod:`.runner` — one span type's stage: prior from s_opt, noise, posterior table, the list;
* :mod:`.figures` — the list along the chainage;
* :mod:`.validation` — the posterior against a campaign's truth (coverage, the list's precision).
"""
