"""Exceptions raised by the :mod:`catenary` package.

Every error message names what was wrong (file, row, column or config key) and what was
expected, so that a user can fix the input without reading the code.
"""


class CatenaryError(Exception):
    """Base class of every error the package raises on purpose."""


class ConfigError(CatenaryError, ValueError):
    """A configuration value is missing or inconsistent; the message names the key."""


class ConvergenceError(CatenaryError, RuntimeError):
    """A nonlinear solve did not converge; no result is returned in that case."""


class NoTautSolutionError(CatenaryError, ValueError):
    """The physics admits no answer with every dropper taut (a target profile that needs a
    dropper to push); the message names the span and dropper. Raised only where slack droppers
    are not allowed, so that the caller can reject that one span and go on."""


class OutOfModelRangeError(CatenaryError, ValueError):
    """An input lies outside the range a reduced model was built for (e.g. a T_MW sample outside
    the fast model's tension interval); the caller may treat that point as infeasible."""


class InputError(CatenaryError, ValueError):
    """An input data file (recording, masts, truth) is malformed.

    The message names the file, the row or column, and what was expected.
    """
