"""The correction's model-error budget (issue [13]).

The dynamic correction (:mod:`catenary.stages.correction`) removes the measuring pantograph's uplift
with a model of the measuring car: its pantograph's masses, stiffnesses and dampings, the force
it pushes with, the speed, the catenary's damping. Each is known only to some accuracy, and an
error in any of them is shared by every span the car measured: a systematic, not a noise. The
budget declares each such input with its standard uncertainty (config ``model_error``,
:mod:`~catenary.stages.model_error.sources`) and measures how far one standard uncertainty moves every
span's corrected W (:mod:`~catenary.stages.model_error.correction`).
"""
