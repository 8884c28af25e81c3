"""The physical model: wires, droppers, supports and pantographs, and what they do.

Span types and physical data (:mod:`.config`, :mod:`.dropper_table`), sections (:mod:`.section`),
the exact tensioned-beam element (:mod:`.beam`), the static model (:mod:`.static`), the dynamic
model and its compiled time loop (:mod:`.dynamics`, :mod:`.dynamics_kernel`), pantographs
(:mod:`.pantograph`), the measuring pass (:mod:`.measuring`), the fast surrogate of the static
model (:mod:`.fast`, :mod:`.chebyshev`), contact-force statistics (:mod:`.contact_statistics`) and
every effect's physics, once (:mod:`.effects`). It imports only :mod:`catenary.plumbing`.
"""
