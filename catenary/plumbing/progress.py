"""Progress of the long steps, for the rule log and the terminal.

A correction pass, an optimiser's evaluations, the diagnosis' candidates and the contact-force
replicates are loops whose length is known (or bounded) in advance. :class:`Progress` logs how
far a loop is, the time elapsed and an estimate of what remains — the mean time per item so far
times the items left, "at most" when the count is only a bound (an optimiser's budget, a
correction's maximum number of passes) — at most once every ``every_s`` seconds and always at the
last item, so that a long job is never silent and a short one is not noisy.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field


@dataclass
class Progress:
    """Progress of a loop of ``total`` items.

    Parameters
    ----------
    log : logging.Logger or None
        Where to report (None: nothing is logged).
    what : str
        What the loop does, e.g. ``"N2 optimiser"`` (starts every line).
    total : int
        Number of items, or their upper bound when ``bound`` is true.
    unit : str
        Name of an item, plural (``"evaluations"``, ``"passes"``).
    bound : bool
        ``total`` is a maximum (the loop may stop earlier): the remaining time is an upper bound.
    every_s : float
        Shortest interval between two lines [s].
    """

    log: logging.Logger | None
    what: str
    total: int
    unit: str
    bound: bool = False
    every_s: float = 15.0
    start_s: float = field(default_factory=time.perf_counter)
    _last_s: float = field(default=-math.inf, repr=False)

    @property
    def elapsed_s(self) -> float:
        """Time since the loop started [s]."""
        return time.perf_counter() - self.start_s

    def remaining_s(self, done: int) -> float:
        """Estimate of the time left after ``done`` items [s]: mean time per item × items left."""
        if done <= 0:
            return math.nan
        return self.elapsed_s / done * max(self.total - done, 0)

    def update(self, done: int, detail: str = "", *, force: bool = False) -> None:
        """Report that ``done`` items are finished, with an optional ``detail``; logged when
        ``every_s`` has passed since the last line, at the last item, or when ``force``."""
        if self.log is None:
            return
        now = time.perf_counter()
        if not (force or done >= self.total or now - self._last_s >= self.every_s):
            return
        self._last_s = now
        left = self.remaining_s(done)
        estimate = ("done" if done >= self.total else
                    f"{'at most ' if self.bound else ''}≈ {left:.0f} s left" if math.isfinite(left) else "")
        self.log.info("%s: %d of %s%d %s%s; %.0f s elapsed%s", self.what, done, "at most " if self.bound else "",
                      self.total, self.unit, f" ({detail})" if detail else "", now - self.start_s,
                      f", {estimate}" if estimate else "")
