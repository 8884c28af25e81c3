"""Which sections one correction job corrects: a long line's sections in batches.

A section's correction is a few seconds of work (≈ 4.5 s for 20 spans on this machine), and each
job pays ≈ 1.5 s more to start a Python process, import the package and read its inputs: on a
10 000-span line's 500 sections a fifth of the correction's cost, and 500 jobs of seconds each
are what a cluster's scheduler is worst at. A job therefore corrects a batch of consecutive
sections (in the sorted order of their ids) — one section per job on a line of up to
:data:`AUTO_JOBS` sections, so that a short line keeps its parallelism and its file names, and
``ceil(sections / AUTO_JOBS)`` per job beyond (``sections_per_correction_job`` sets it instead,
for a cluster with more cores than that). A section that also measures the model-error budget
takes 3–5 times longer than the others: it is a batch of its own, started first.
"""

from __future__ import annotations

import math

__all__ = ["AUTO_JOBS", "batch_name", "section_batches"]

#: Correction jobs a long line is cut into when ``sections_per_correction_job`` is not set.
AUTO_JOBS = 100


def batch_name(sections: list[str]) -> str:
    """A batch's name in the file names: its only section's id, or its first section's id and
    how many follow (``L0100+4``: L0100 and the next four)."""
    return sections[0] if len(sections) == 1 else f"{sections[0]}+{len(sections) - 1}"


def section_batches(section_ids: list[str], alone: list[str] | set[str] = (),
                    sections_per_job: int | None = None) -> dict[str, list[str]]:
    """The correction's batches: ``{name: [section ids]}``, every section in exactly one, in the
    sorted order of the ids (module docs).

    Parameters
    ----------
    section_ids : list of str
        The projected sections.
    alone : collection of str
        Sections that get a batch of their own (those measuring the model-error budget).
    sections_per_job : int, optional
        Sections per batch; default: one up to :data:`AUTO_JOBS` sections, else
        ``ceil(len(section_ids) / AUTO_JOBS)``. A section of ``alone`` ends the batch before it.

    Returns
    -------
    dict of str to list of str
        In the sorted order of the sections (:func:`batch_name` as keys).
    """
    ids = sorted(set(section_ids))
    alone = set(alone)
    per = max(1, math.ceil(len(ids) / AUTO_JOBS)) if sections_per_job is None else sections_per_job
    if per < 1:
        raise ValueError(f"sections_per_job: expected an integer ≥ 1, got {per}")
    batches, current = [], []
    for section in ids:
        if section in alone:          # it cuts the run: a batch is consecutive sections
            if current:
                batches.append(current)
                current = []
            batches.append([section])
            continue
        current.append(section)
        if len(current) == per:
            batches.append(current)
            current = []
    if current:
        batches.append(current)
    return {batch_name(b): b for b in batches}
