"""catenary.plumbing.progress: what a long step writes to its rule log."""

import logging

import pytest

from catenary.plumbing.progress import Progress


def test_progress_lines_carry_the_count_elapsed_time_and_an_estimate(caplog):
    log = logging.getLogger("test.progress")
    progress = Progress(log, "N2 optimiser", 4, "evaluations", bound=True, every_s=0.0)
    progress.start_s -= 10.0                      # as if the first item took 10 s
    with caplog.at_level(logging.INFO, logger="test.progress"):
        progress.update(1, "best J so far 3.000")
        progress.update(4)
    first, last = caplog.messages
    # 10 s for 1 item, 3 items left: ≈ 30 s, an upper bound since 4 is the budget
    assert first.startswith("N2 optimiser: 1 of at most 4 evaluations (best J so far 3.000); 10 s elapsed")
    assert first.endswith("at most ≈ 30 s left")
    assert last.endswith("done")


def test_progress_is_rate_limited_but_always_logs_the_last_item(caplog):
    log = logging.getLogger("test.progress")
    progress = Progress(log, "correction", 100, "passes", every_s=3600.0)
    progress.start_s -= 100.0                     # a clock far from 0: the estimate's ratio is exact to 1e-6
    with caplog.at_level(logging.INFO, logger="test.progress"):
        for k in range(1, 101):
            progress.update(k)
    assert [m.split(";")[0] for m in caplog.messages] == ["correction: 1 of 100 passes", "correction: 100 of 100 passes"]
    assert progress.remaining_s(50) == pytest.approx(progress.elapsed_s, rel=1e-3)   # half done: as long again
