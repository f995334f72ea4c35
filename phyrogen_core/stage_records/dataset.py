"""``dataset``: a sharded, resumable dataset with a Parquet manifest (docs/datasets.md)."""

from __future__ import annotations

from typing import Literal

from .base import Count, StageRequest, StageResult


class DatasetRequest(StageRequest, stage="dataset"):
    generators: str
    """A name, comma-separated names, or 'all' (the paper's six)."""
    out: str
    """The dataset's folder: new, empty, or this request's dataset (then resumed)."""
    seeds: str | None = None
    """Seed, range or list, e.g. '1-1000'; or None with ``count``."""
    count: int | None = None
    """How many seeds per generator, from ``start``."""
    start: int | None = None
    """The first seed with ``count`` (None: 1)."""
    overrides: tuple[str, ...] = ()
    """``KEY=VALUE`` for every puzzle, or a sweep: ``KEY=LOW:HIGH[:STEP]`` or ``KEY=A,B,C``."""
    sweep: Literal["cross", "zip"] = "cross"
    shard_size: int = 1000
    mjcf: bool = False
    difficulty: bool = False
    difficulty_runs: int | None = None
    difficulty_checks: int | None = None
    workers: int = 2
    ray: str | None = None
    """Make the puzzles as Ray tasks: 'local' or a cluster's address (None: local worker processes)."""


class DatasetResult(StageResult, stage="dataset"):
    """Every entry has its manifest row (failed seeds are rows too, so a finished dataset exits 0)."""

    entries: Count
    ok: Count
    failed: Count
    generated: Count
    """Entries made by this run (the rest were found done)."""
    reused: Count
    seconds: float
    puzzles_per_hour: float
    manifest: str

    def problem(self) -> str | None:
        if self.ok + self.failed != self.entries or self.generated + self.reused != self.entries:
            return (f"'ok' {self.ok} and 'failed' {self.failed}, 'generated' {self.generated} and 'reused' "
                    f"{self.reused} must each add up to 'entries' {self.entries}")
        return None
