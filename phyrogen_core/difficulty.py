"""A puzzle's measured difficulty: how often a reference planner solves it within a budget of checks.

The measurement itself (planner runs) belongs to the solver
(:mod:`solver.benchmark.difficulty`); this module holds only the typed
result, which :class:`~phyrogen_core.record.PuzzleRecord` writes into
``puzzle.json`` under ``difficulty`` when it was asked for. Every number in
it is counted, never timed (runs, successes, collision checks), so the same
puzzle, run count and budget give the same value on any machine.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Difficulty:
    """``runs`` seeded runs of ``planner`` (its registry name and version), each ended at its first
    solution or after ``budget_checks`` collision checks: how many succeeded, the success rate's
    95 % Wilson interval, and the median collision checks to the first solution among the
    successes (None when none succeeded)."""

    planner: str
    planner_version: str
    runs: int
    budget_checks: int
    successes: int
    success_low: float
    success_high: float
    median_checks_to_first: float | None

    def __post_init__(self) -> None:
        if not (isinstance(self.runs, int) and self.runs >= 1):
            raise ValueError(f"difficulty runs must be a whole number of at least 1, got {self.runs!r}")
        if not (isinstance(self.successes, int) and 0 <= self.successes <= self.runs):
            raise ValueError(f"difficulty successes must be 0..runs ({self.runs}), got {self.successes!r}")
        if not (isinstance(self.budget_checks, int) and self.budget_checks >= 1):
            raise ValueError(f"difficulty budget_checks must be at least 1, got {self.budget_checks!r}")
        if not 0.0 <= self.success_low <= self.success_rate <= self.success_high <= 1.0:
            raise ValueError(f"difficulty interval [{self.success_low!r}, {self.success_high!r}] must lie in "
                             f"[0, 1] and hold the success rate {self.success_rate!r}")
        if (self.median_checks_to_first is None) != (self.successes == 0):
            raise ValueError("difficulty median_checks_to_first must be given exactly when a run succeeded, "
                             f"got {self.median_checks_to_first!r} with {self.successes} successes")

    @property
    def success_rate(self) -> float:
        return self.successes / self.runs
