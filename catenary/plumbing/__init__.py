"""Plumbing: what every layer uses and that knows no physics.

Errors (:mod:`.errors`), logging of a rule's job (:mod:`.logs`), progress lines (:mod:`.progress`),
Parquet intermediates with their provenance (:mod:`.parquet`), the shipped JSON schemas
(:mod:`.schema`), figures made without choosing Matplotlib's backend (:mod:`.plots`), and the
process-wide tuning a process's entry point asks for (:mod:`.heap`, :mod:`.blas`). It imports
nothing else of :mod:`catenary`.
"""
