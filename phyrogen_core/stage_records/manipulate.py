"""``manipulate``: puzzles' solutions executed by a mobile KUKA iiwa in PyBullet."""

from __future__ import annotations

from dataclasses import dataclass

from .base import Count, JsonObject, Record
from .shared import FoldersRequest, OutputResult


class ManipulateRequest(FoldersRequest, stage="manipulate"):
    out: str = "output/manipulation"
    video: bool = True
    table: str | None = None
    """Also write a Markdown summary table to this file."""
    scale: float | None = None
    """Scene metres per puzzle metre for every puzzle (None: each generator's physical scale)."""
    gui: bool = False
    progress: bool = False
    """Show a progress bar on stderr."""
    benchmark: str | None = None
    """A benchmark's output folder: every least-cost LA-RRT solution in its journal is tried, then the
    certificate (None: the puzzle's best solution, then the certificate)."""


@dataclass(frozen=True)
class ManipulationOutcome(Record):
    """One puzzle's report (its ``report.json``) and its output folder."""

    puzzle: str
    folder: str
    generator: str
    seed: int
    scale: float
    solution: str
    """Which solution the numbers are of."""
    solutions_tried: Count
    success: bool
    target_at_goal: bool
    actions: Count
    regrasps: Count
    planning_seconds: float
    execution_seconds: float
    simulated_seconds: float
    benchmark_seconds: float
    max_penetration: float
    message: str
    attempts: tuple[JsonObject, ...]
    """Every solution tried, in order, each with its per-action reports (``manipulation.execution_records``)."""
    contact: JsonObject | None
    """The unplanned contact that stopped the last attempt, if one did."""


class ManipulateResult(OutputResult, stage="manipulate"):
    reports: tuple[ManipulationOutcome, ...]

    def done(self) -> bool:
        return all(report.success for report in self.reports)
