"""Registration of the mast table onto each run's trace (issue [12]).

A measuring car's chainage comes from its odometer: offset by metres where the run starts,
scaled by the wheel's error, drifting along the run. The mast table comes from the
infrastructure's database: a mast missing here, one that no longer exists there, every chainage
off by decimetres. Cutting a recording into spans at the table's chainages would then cut most
spans in the wrong place, and give each a W that looks measured and is not. This subpackage
finds the supports in each run's own trace (:mod:`.supports`: the stagger's reversals, or the
droppers' kinks in the height with the dynamic pass's lag, :mod:`.lag`), fits per section the map
from table to recorded chainage (:mod:`.mapping`), places every mast, flags those missing from or
extra in the table, and refuses a section it cannot register (:mod:`.runner`); :mod:`.outputs`
writes what the projection reads and what a user checks.
"""

from .mapping import ChainageMap, fit_map
from .runner import (MAST_COLUMNS, REGISTRATION_COLUMNS, SECTION_COLUMNS, RunRegistration, masts_from_trace,
                     register_run, register_runs, unregistered_run)
from .settings import RegistrationSettings

__all__ = ["ChainageMap", "MAST_COLUMNS", "REGISTRATION_COLUMNS", "RegistrationSettings", "RunRegistration",
           "SECTION_COLUMNS", "fit_map", "masts_from_trace", "register_run", "register_runs", "unregistered_run"]
