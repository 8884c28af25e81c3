"""The stages of the paper and beyond, each a module or a subpackage.

In the order a run goes through them: the dynamic correction (:mod:`.correction`), the inversion
for dropper lengths (:mod:`.inversion`), the correction's model error (:mod:`.model_error`), the
sensitivity and tension studies (:mod:`.sensitivity`, :mod:`.tension_impact`), the identification
of the random inputs (:mod:`.identification`), the contact-force study (:mod:`.contact_force`),
the discrepancy diagnosis (:mod:`.diagnosis`) and the maintenance posteriors
(:mod:`.maintenance`). A stage imports the layers below (:mod:`catenary.measurement`,
:mod:`catenary.physics`, :mod:`catenary.plumbing`) and the stages below its own: the diagnosis and
the maintenance stand on the identification and the contact-force study, which stand on the
first four; stages of one level do not import each other.
"""
