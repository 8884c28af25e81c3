"""Logging set-up shared by the rule scripts: one log file per rule, also on stderr.

A rule script that stops on an error the package raises on purpose (:class:`CatenaryError`:
bad input, bad config, a solve that did not converge) ends with that error's message as one
line in its log and on stderr, and exit status 1 — no traceback, since the message already
names the file, the row or key and what was expected. Any other exception is a bug: its
traceback goes to the log as well as to stderr.
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path

from .errors import CatenaryError


def rule_logger(name: str, log_path: str | Path | None) -> logging.Logger:
    """A logger writing to ``log_path`` (the rule's ``log:``) and to stderr."""
    logger = logging.getLogger(f"catenary.{name}")
    logger.setLevel(logging.INFO)
    logger.handlers.clear()
    fmt = logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s")
    handlers: list[logging.Handler] = [logging.StreamHandler(sys.stderr)]
    if log_path:
        Path(log_path).parent.mkdir(parents=True, exist_ok=True)
        handlers.append(logging.FileHandler(log_path, mode="w"))
    for h in handlers:
        h.setFormatter(fmt)
        logger.addHandler(h)
    sys.excepthook = _excepthook(logger)
    return logger


def _excepthook(logger: logging.Logger):
    """An uncaught-exception hook: one line for a :class:`CatenaryError`, a traceback otherwise."""
    def hook(kind, value, traceback):
        if issubclass(kind, CatenaryError):
            logger.error("%s: %s", kind.__name__, value)
        else:
            logger.critical("unexpected %s (a bug, not a problem with the input): %s", kind.__name__, value,
                            exc_info=(kind, value, traceback))
        for handler in logger.handlers:
            handler.flush()
    return hook
