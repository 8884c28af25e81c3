"""A campaign's recording shipped with the repository, used in place of simulating it.

The default run (``make run``) processes the virtual campaign of ``config/campaign.yaml``: a
recording car simulated over 177 spans with the dynamic model, ≈ 85 s of work on 2 cores before
the pipeline proper starts. Its outputs are a pure function of three files — the campaign's truth,
the catenary data and the pantograph models — and of the code, so the repository ships them
(``data/default_campaign``, ≈ 0.3 MB) with a manifest of the SHA-256 of the three files they were
written from. The workflow copies them into ``{results}/campaign/`` instead of simulating while
the manifest matches the configured files byte for byte; edit any of the three and the campaign
is simulated again. ``make default-data`` rewrites the copy; a slow test regenerates the campaign
and compares it with the copy, so a change of the code that moves the campaign cannot leave a
stale copy behind (docs/running.md).

This module is imported when Snakemake builds its DAG: it imports nothing heavy.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

from catenary.plumbing.errors import InputError

__all__ = ["FILES", "MANIFEST", "SOURCES", "copy_out", "file_digest", "matches", "write_copy"]

#: The campaign's outputs that the copy holds (rule ``campaign`` writes them, and the CSV of the
#: recording, which the copy's rule writes from the Parquet file).
FILES = ("recording.parquet", "masts.csv", "masts_truth.csv", "truth.parquet", "truth_runs.parquet", "survey.csv")

#: The manifest's name in the copy's folder.
MANIFEST = "manifest.json"

#: The workflow configuration's keys naming the files the campaign's outputs depend on.
SOURCES = ("campaign", "catenary", "pantographs")


def file_digest(path: str | Path) -> str:
    """SHA-256 (hex) of a file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _manifest(directory: Path) -> dict:
    path = directory / MANIFEST
    try:
        with open(path, encoding="utf-8") as f:
            manifest = json.load(f)
    except json.JSONDecodeError as error:
        raise InputError(f"{path}: not a manifest (JSON: {error}); restore it from the repository (git checkout) "
                         "or rewrite the copy (make default-data)") from None
    if not isinstance(manifest, dict):
        raise InputError(f"{path}: expected a JSON object with 'sources' and 'files'")
    return manifest


def matches(directory: str | Path | None, sources: dict[str, str]) -> tuple[bool, str]:
    """Whether the copy in ``directory`` was written from exactly the files ``sources`` names.

    Parameters
    ----------
    directory : path or None
        The copy's folder (the configuration's ``campaign_copy``); None: no copy.
    sources : dict
        :data:`SOURCES` → the configured file's path.

    Returns
    -------
    (bool, str)
        Whether the copy can stand for the simulation, and why (a sentence for the log).

    Raises
    ------
    InputError
        The copy's manifest is not a JSON object (cut short, edited by hand).
    """
    if directory is None:
        return False, "no campaign_copy configured: the campaign is simulated"
    directory = Path(directory)
    missing = [name for name in (*FILES, MANIFEST) if not (directory / name).is_file()]
    if missing:
        return False, f"campaign_copy {directory}: {', '.join(missing)} missing: the campaign is simulated"
    written = _manifest(directory).get("sources", {})
    changed = [f"{key} ({sources[key]})" for key in SOURCES
               if written.get(key, {}).get("sha256") != file_digest(sources[key])]
    if changed:
        return False, (f"campaign_copy {directory} was written from other files than {', '.join(changed)}: "
                       "the campaign is simulated")
    return True, f"campaign_copy {directory} written from these very files: copied, not simulated"


def copy_out(directory: str | Path, campaign_dir: str | Path) -> None:
    """Copy the copy's files into ``campaign_dir`` (``{results}/campaign``), each checked against
    the SHA-256 its manifest gives.

    Raises
    ------
    InputError
        A file whose bytes are not those the manifest records (truncated, edited, or a Git LFS
        pointer in place of the file), named with what to do.
    """
    directory, campaign_dir = Path(directory), Path(campaign_dir)
    recorded = _manifest(directory).get("files", {})
    campaign_dir.mkdir(parents=True, exist_ok=True)
    for name in FILES:
        if file_digest(directory / name) != recorded.get(name):
            raise InputError(f"{directory / name}: its SHA-256 is not the one {directory / MANIFEST} records; "
                             "restore it from the repository (git checkout) or rewrite the copy (make default-data)")
        shutil.copyfile(directory / name, campaign_dir / name)


def write_copy(campaign_dir: str | Path, directory: str | Path, sources: dict[str, str]) -> Path:
    """Copy a simulated campaign's outputs (``{results}/campaign``) into ``directory`` and write the
    manifest of the files ``sources`` names (:data:`SOURCES` → path). Returns the manifest's path."""
    campaign_dir, directory = Path(campaign_dir), Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    for name in FILES:
        shutil.copyfile(campaign_dir / name, directory / name)
    manifest = {
        "what": "outputs of the workflow's rule campaign, copied in place of simulating it (catenary.measurement.shipped)",
        "sources": {key: {"path": str(sources[key]), "sha256": file_digest(sources[key])} for key in SOURCES},
        "files": {name: file_digest(directory / name) for name in FILES},
    }
    path = directory / MANIFEST
    path.write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
    return path


if __name__ == "__main__":        # python -m catenary.measurement.shipped CAMPAIGN_DIR COPY_DIR CAMPAIGN CATENARY PANTOGRAPHS
    import sys

    if len(sys.argv) != 6:
        sys.exit("usage: python -m catenary.measurement.shipped CAMPAIGN_DIR COPY_DIR CAMPAIGN CATENARY PANTOGRAPHS")
    print(write_copy(sys.argv[1], sys.argv[2], dict(zip(SOURCES, sys.argv[3:]))))
