"""The names inside a puzzle folder and the rule for names that build paths.

A puzzle lives in one folder, ``<out>/<generator>/<name>/`` (:mod:`phyrogen_core.folder`); a dataset
keeps its puzzles in shard folders of its root. These are the fixed names every layer agrees on.
"""

from __future__ import annotations

from pathlib import Path

METADATA_FILE = "puzzle.json"
BEST_SOLUTION = Path("solutions") / "la_rrt_best.json"
"""The benchmark's lowest-cost solution, the one the manipulation stage executes (inside a puzzle folder)."""
MAX_NAME_LENGTH = 200
"""The longest puzzle or generator name: ``<name>.blend`` and friends stay within file-name limits."""
DATASET_FILE = "dataset.json"
"""Marks a dataset root (``phyrogen dataset``): its puzzles lie in shard folders,
``<root>/shard-<nnnnn>/<generator>/<name>/``, each shard an output root of its own."""
SHARD_PREFIX = "shard-"


def shard_name(index: int) -> str:
    """The folder of shard ``index`` (0-based) of a dataset: ``shard-00000``, ``shard-00001``, ..."""
    return f"{SHARD_PREFIX}{index:05d}"


STALE_FOLDER = "stale"
"""Where :func:`~phyrogen_core.stage_writes.stage_directory` keeps the renders and solutions of a puzzle
that was regenerated differently."""


def name_problem(name: object) -> str | None:
    """Why ``name`` cannot name a puzzle (or a generator's folder), or None when it can.

    The one rule for names that build paths: a non-empty string of at most
    :data:`MAX_NAME_LENGTH` printable characters, without ``/`` or ``\\``, not
    starting with ``.`` (which also excludes ``.`` and ``..``, and the
    temporary folders of :func:`atomic_directory`). Such a name stays one
    entry inside the folder it is joined to.
    """
    if not isinstance(name, str) or not name:
        return "must be a non-empty string"
    if len(name) > MAX_NAME_LENGTH:
        return f"is {len(name)} characters long; valid names have at most {MAX_NAME_LENGTH}"
    if "/" in name or "\\" in name or name.startswith(".") or not name.isprintable():
        return ("cannot name an entry inside a folder; valid names have no slashes, no control characters "
                "and do not start with '.'")
    return None
