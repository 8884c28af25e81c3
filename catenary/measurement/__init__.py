"""Measurements: a recording read, registered and cut into spans, and the campaign that writes one.

Reading recordings and mast tables (:mod:`.recording`), registering the masts onto each run's
trace (:mod:`.registration`), projecting each span onto its chord (:mod:`.projection`), the
channels besides the height and a crew's survey (:mod:`.channels`), the repeatability of runs
(:mod:`.repeatability`), and the virtual campaign: its truth (:mod:`.truth`), the recording car
(:mod:`.recording_car`), the simulation (:mod:`.campaign`), the shipped default recording
(:mod:`.shipped`) and the checks of results against the truth (:mod:`.truth_checks`). It imports
:mod:`catenary.physics` and :mod:`catenary.plumbing`.
"""
