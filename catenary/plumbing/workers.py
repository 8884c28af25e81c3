"""Blocks of independent items (spans) in forked worker processes: a job uses the cores it is given.

A stage whose items are independent — each span's posterior, each span's leave-one-out check —
splits them into contiguous blocks of a fixed size and maps a function over the blocks, in
``workers`` forked processes or, with one worker, in this one. The function reads what it needs
from the state the parent held when the pool forked (nothing is pickled but the block's bounds
and its result). The blocks are the same whatever the number of workers, so each block's
arithmetic is too and the answer is the same, bit for bit, for any number of workers (each
stage's test checks this). The size is fixed rather than the workers' share because the
arithmetic of an item may depend on its block's size: a BLAS product over few rows takes another
kernel, with another order of its sums, than over many (measured: a span's posterior mode moved
by 2e-9 in normal scores between a block of 80 spans and two of 10 and 70).

A computation called many times in turn — J at each step of an optimiser — has no items to hand
out once: :class:`KeptProcesses` forks its helpers once and keeps them, each serving its part of
every call until the caller closes them; the caller's own process computes the first part.

Each process should use one BLAS thread (:mod:`catenary.plumbing.blas`, before NumPy loads), so
that ``workers`` processes use ``workers`` cores instead of spinning threads against each other.
"""

from __future__ import annotations

import multiprocessing
import os
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import TypeVar

__all__ = ["KeptProcesses", "call_each", "map_blocks", "map_each"]

T = TypeVar("T")

#: The function and blocks a forked worker reads (set by :func:`map_blocks` before the pool forks).
_TASK: dict = {}


def _run(index: int):
    start, stop = _TASK["blocks"][index]
    return _TASK["function"](start, stop)


def map_blocks(function: Callable[[int, int], T], n_items: int, workers: int, block_size: int) -> list[T]:
    """``function(start, stop)`` over blocks of ``block_size`` items covering ``range(n_items)``
    (the last one shorter), results in block order.

    Parameters
    ----------
    function : callable
        Called with a block's bounds; it must give a block's result from that block's items alone.
    n_items : int
    workers : int
        Forked processes (1 or less: every block in this process, in turn).
    block_size : int
        Items per block, whatever the number of workers (module docstring).
    """
    bounds = [(start, min(start + block_size, n_items)) for start in range(0, n_items, block_size)] or [(0, 0)]
    if workers <= 1 or len(bounds) <= 1:
        return [function(start, stop) for start, stop in bounds]
    _TASK.update(function=function, blocks=bounds)
    try:
        with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("fork")) as pool:
            return list(pool.map(_run, range(len(bounds))))
    finally:
        _TASK.clear()


def map_each(function: Callable[[int], T], n_items: int, workers: int, block_size: int) -> list[T]:
    """``function(k)`` of each item ``k`` of ``range(n_items)``, in order: :func:`map_blocks` over
    blocks of ``block_size`` items, each block's values listed and the blocks joined."""
    blocks = map_blocks(lambda start, stop: [function(k) for k in range(start, stop)], n_items, workers, block_size)
    return [value for block in blocks for value in block]


def call_each(tasks: Sequence[Callable[[], T]], workers: int) -> list[T]:
    """Each of ``tasks`` called once, their results in order: independent tasks (a figure, a
    table, a test) handed one at a time to ``workers`` forked processes (:func:`map_each` over
    blocks of one); put the longest first."""
    return map_each(lambda k: tasks[k](), len(tasks), workers, 1)


def _serve(function: Callable, connection) -> None:
    """A kept helper's loop: call ``function(*arguments)`` for each message until ``None``."""
    while True:
        try:
            arguments = connection.recv()
        except EOFError:                 # the caller went away
            break
        if arguments is None:
            break
        try:
            connection.send((True, function(*arguments)))
        except Exception as exc:         # noqa: BLE001 - handed to the caller, which raises it
            connection.send((False, (exc, traceback.format_exc())))
    connection.close()


class KeptProcesses:
    """``workers − 1`` forked helper processes, kept for many calls of one function.

    :meth:`map` computes ``function(*parts[0])`` in this process and ``function(*parts[i])`` in
    helper i meanwhile; the helpers read what they need from the state this process held when
    it forked them (only the parts' arguments and results are pickled). A function whose result
    is the same computation whichever process runs it gives the same answer, bit for bit, for
    any number of workers. Use as a context manager (the helpers stop on exit); in a process
    forked from the owner (a worker of :func:`map_blocks`) :meth:`map` computes every part in
    turn, since the helpers are not its children.

    Parameters
    ----------
    function : callable
        Called with the arguments of one part.
    workers : int
        Processes in all, this one included (1 or less: no helper).
    """

    def __init__(self, function: Callable, workers: int):
        self.function = function
        self._owner = os.getpid()
        self._helpers = []
        context = multiprocessing.get_context("fork")
        try:
            for _ in range(max(int(workers), 1) - 1):
                mine, theirs = context.Pipe()
                process = context.Process(target=_serve, args=(function, theirs), daemon=True)
                process.start()
                theirs.close()
                self._helpers.append((process, mine))
        except BaseException:
            self.close()
            raise

    @property
    def workers(self) -> int:
        """Processes that share each call (this one included)."""
        return len(self._helpers) + 1

    def map(self, parts: Sequence[tuple]) -> list:
        """``function(*part)`` of each part, in order; at most :attr:`workers` parts."""
        if len(parts) > self.workers:
            raise ValueError(f"parts: at most {self.workers} (the workers), got {len(parts)}")
        if os.getpid() != self._owner or not self._helpers:
            return [self.function(*part) for part in parts]
        helpers = self._helpers[:len(parts) - 1]
        for (_, connection), part in zip(helpers, parts[1:]):
            connection.send(tuple(part))
        try:
            out = [self.function(*parts[0])] if parts else []
        finally:                         # every helper's answer read, so that none is left for the next call
            answers = [self._receive(process, connection) for process, connection in helpers]
        for ok, value in answers:
            if not ok:
                exc, where = value
                raise exc from RuntimeError(f"in a helper process:\n{where}")
            out.append(value)
        return out

    @staticmethod
    def _receive(process, connection) -> tuple:
        try:
            return connection.recv()
        except EOFError:
            raise RuntimeError(f"a helper process (pid {process.pid}) stopped: exit code {process.exitcode}") from None

    def close(self) -> None:
        """Stop the helpers (the owner only; idempotent)."""
        if os.getpid() != self._owner:
            return
        for process, connection in self._helpers:
            try:
                connection.send(None)
            except (BrokenPipeError, OSError):
                pass
            connection.close()
        for process, _ in self._helpers:
            process.join(timeout=5)
            if process.is_alive():
                process.kill()
                process.join()
        self._helpers = []

    def __enter__(self) -> "KeptProcesses":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

