"""The discrepancy workflow: where the identification model and the data disagree, which
missing physical effect explains it, and how much of the gap adding it closes.

* :mod:`.candidates` — the candidate effects, their parameters, nulls and allowed ranges;
* :mod:`.model` — design rows → model W with the active effects (the campaign's physics);
* :mod:`.problem` — J over the base laws and the effects' magnitudes, refits, curvature;
* :mod:`.locate` — residuals, whitened eigenvalues with a bootstrap band, Mahalanobis
  distances, catch-all gains, score screen, detectable magnitudes (the Fisher information is
  :mod:`catenary.stages.identification.scoring`'s);
* :mod:`.refits` — one candidate's score screen, refit and likelihood-ratio test, and the
  candidates of a step in worker processes;
* :mod:`.runner` — the forward selection (locate, name, add, repeat) and its verdicts;
* :mod:`.settings` — the ``diagnosis`` config block;
* :mod:`.outputs`, :mod:`.figures` — tables, summary and figures of a run.
"""
