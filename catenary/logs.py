"""Logging set-up shared by the rule scripts: one log file per rule, also on stderr."""

from __future__ import annotations

import logging
import sys
from pathlib import Path


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
    return logger
