"""``audit``: exported puzzles checked again: certificate replayed in PyBullet, every object tried as
superfluous with a large budget."""

from __future__ import annotations

from dataclasses import dataclass

from .base import Count, Record
from .shared import FolderRequest, TimedResult


class AuditRequest(FolderRequest, stage="audit"):
    """``folder``: a puzzle folder, or a folder of generated puzzles (all of them)."""

    budget: int | None = None
    """Collision queries per attempt with an object fixed (None: the default, 25 x the Maker's judge budget)."""
    out: str = "output/audit"
    """The folder of ``audit.json`` and ``audit.md``."""
    workers: int = 2


@dataclass(frozen=True)
class AuditPlan(Record):
    """A checked audit before its first attempt."""

    puzzles: Count
    tasks: Count
    """Attempts: a certificate check per puzzle and one per object tried."""
    budget: Count
    second_budget: Count
    """Collision checks of the second judge (the paper's LA-RRT) per attempt."""
    referee: str
    """The physics engine that replays each certificate."""
    resolution: float
    """Metres between the replay's samples."""
    tolerance: float
    """The penetration (metres) above which a replay fails."""


@dataclass(frozen=True)
class AuditedPuzzle(Record):
    puzzle: str
    generator: str
    seed: int
    ok: bool
    superfluous: tuple[str, ...]
    """Objects found superfluous (solved with them fixed)."""
    failures: tuple[str, ...]
    """One line per failure, naming the object or the certificate."""


class AuditResult(TimedResult, stage="audit"):
    puzzles: tuple[AuditedPuzzle, ...]
    report_json: str
    report_markdown: str

    def done(self) -> bool:
        return all(p.ok for p in self.puzzles)
