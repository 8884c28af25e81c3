"""Iterative dynamic correction of the measuring pantograph's uplift (paper §2.2, Fig. 5).

Its settings (:mod:`.settings`), the loop over a section's runs (:mod:`.runner`), the tables it
writes (:mod:`.outputs`) and the lag of its measuring pass, which the registration and the
projection use (:mod:`.lag`, imported from there: it needs the registration's fit, which a
section's correction job would otherwise import for nothing: its imports 0.78 → 0.62 s in each
of a long line's jobs).
"""

from .outputs import corrected_of_type, corrected_schema, correction_summary, profiles_schema
from .runner import RunCorrection, consecutive_runs, correct_spans, measuring_conditions
from .settings import CorrectionSettings

__all__ = ["CorrectionSettings", "RunCorrection", "consecutive_runs", "correct_spans", "corrected_of_type",
           "corrected_schema", "correction_summary", "measuring_conditions", "profiles_schema"]
