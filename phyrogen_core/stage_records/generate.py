"""``generate``: certified puzzles for generators and seeds (or a named suite)."""

from __future__ import annotations

from dataclasses import dataclass

from .base import Count, Record, StageRequest
from .shared import TimedResult


class GenerateRequest(StageRequest, stage="generate"):
    generators: str | None = None
    """A name, comma-separated names, or 'all' (the paper's six; None is 'all')."""
    suite: str | None = None
    """Every generator of a named suite with its parameters (``phyrogen_core.suites``), in place of
    ``generators`` and ``overrides``."""
    seeds: str = "1-4"
    """Seed, range or list: '3', '1-4', '1,3,5-7'."""
    overrides: tuple[str, ...] = ()
    """``KEY=VALUE`` parameter overrides of the one generator named."""
    out: str = "output"
    workers: int = 2
    mjcf: bool = False
    """Also write each puzzle's MJCF (``<folder>/mjcf/<name>.xml``)."""
    difficulty: bool = False
    """Measure each puzzle's difficulty and write it into puzzle.json."""
    difficulty_runs: int | None = None
    difficulty_checks: int | None = None
    keep_rows: bool = True
    """Keep every puzzle's row in the result; without, only the counts (a run of a hundred million seeds
    holds little memory)."""


@dataclass(frozen=True)
class GeneratedPuzzle(Record):
    """One puzzle of a generation (a row of the result)."""

    generator: str
    seed: int
    objects: Count
    actions: Count
    """Actions of the (defragmented) certificate."""
    seconds: float
    folder: str | None
    """None when the puzzle failed."""
    error: str | None
    """The first line of what went wrong; None when the puzzle was made."""

    def problem(self) -> str | None:
        if (self.folder is None) == (self.error is None):
            return "a puzzle has either a folder or an error"
        return None


class GenerateResult(TimedResult, stage="generate"):
    puzzles: tuple[GeneratedPuzzle, ...]
    """Every puzzle's row, in the order asked for (empty when the request kept none)."""
    ok: Count
    failed: Count

    def done(self) -> bool:
        return not self.failed

    def problem(self) -> str | None:
        errors = sum(p.error is not None for p in self.puzzles)
        if self.puzzles and (len(self.puzzles) != self.ok + self.failed or errors != self.failed):
            return (f"{len(self.puzzles)} puzzles, {errors} of them failed, do not add up to 'ok' {self.ok} and "
                    f"'failed' {self.failed}")
        return None
