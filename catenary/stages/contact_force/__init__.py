"""Contact-force statistics over random sections of the identified laws (the paper's next step).

* :mod:`.laws` — the identified laws (``s_opt.csv``) and named effects (``findings.csv``);
* :mod:`.draws` — a random section, group by group, with the campaign's sampling code;
* :mod:`.runs` — dynamic runs, EN 50318 / EN 50367 criteria and limits, static features;
* :mod:`.summary` — per-criterion statistics and violation probabilities with binomial intervals;
* :mod:`.sensitivity` — Sobol indices of the criteria over the input groups (pick-freeze);
* :mod:`.settings` — the ``contact_force`` config block; :mod:`.outputs` — files and figures.
"""
