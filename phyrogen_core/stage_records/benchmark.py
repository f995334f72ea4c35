"""``benchmark``: planners on puzzle folders (OMPL logs, database, plots), resumed from its journal."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from .base import Count, JsonObject, Record, RecordError, StageRequest, read_value
from .shared import OutputResult


class BenchmarkRequest(StageRequest, stage="benchmark"):
    puzzles: str = "output"
    """A folder of puzzle folders."""
    generator: str = "all"
    """Generators to include: 'all' found, or comma-separated names."""
    planners: str = "all"
    """'all' (every planner outside a group), a group, or comma-separated names, in any mix."""
    profile: str = "quick"
    runs: int | None = None
    """Runs per planner and puzzle (None: the profile's)."""
    time_limit: float | None = None
    """Seconds per run for every puzzle (None: the profile's); with a budget, the wall-clock backstop."""
    seed: int = 0
    out: str = "output/benchmark"
    workers: int = 2
    ray: str | None = None
    """Run on Ray: 'local' or a cluster's address (None: local worker processes)."""
    until: Literal["limit", "first"] = "limit"
    budget_checks: int | None = None
    budget_cpu: float | None = None
    budget_from_paper: bool = False
    save_solutions: bool = True
    """Save LA-RRT's best path per puzzle (``solutions/la_rrt_best.json``)."""
    progress: bool = False
    """Show a progress bar on stderr."""


@dataclass(frozen=True)
class BenchmarkPlan(Record):
    """A checked benchmark before it runs: what :func:`phyrogen.stages.benchmark.plan` tells."""

    puzzles: Count
    planners: Count
    runs: Count
    """Runs per planner and puzzle."""
    profile: str
    until_first: bool
    estimate_seconds: float
    """Wall-clock seconds the runs still to do take, roughly."""
    workers: Count
    jobs: Count
    done: Count
    """Runs the output folder's journal already holds (resumed, not run again)."""
    journal: str


@dataclass(frozen=True)
class BenchmarkCell:
    """One puzzle and planner of a benchmark's summary (``summary.json``'s ``cells``), as the panel shows it."""

    puzzle: str
    planner: str
    runs: int
    successes: int
    time_to_first: float | None
    """Median seconds to a first solution over all runs; None when not within the budget (or no estimate)."""


class BenchmarkResult(OutputResult, stage="benchmark"):
    """The output's paths and ``summary.json`` whole (its own format, under ``summary``)."""

    database: str
    results_page: str
    crashed: Count
    """Runs that crashed."""
    unsaved_solutions: tuple[str, ...]
    """One line per puzzle whose best solution could not be saved."""
    summary: JsonObject

    def done(self) -> bool:
        return not (self.crashed or self.unsaved_solutions)

    @property
    def cells(self) -> tuple[BenchmarkCell, ...]:
        return _cells(self.summary, "'summary'")

    def problem(self) -> str | None:
        try:
            _cells(self.summary, "'summary'")
        except RecordError as exc:
            return str(exc)
        return None


def _cells(summary: dict, where: str) -> tuple[BenchmarkCell, ...]:
    if "cells" not in summary:
        raise RecordError(f"{where}: missing key 'cells'")
    cells = read_value(summary["cells"], tuple[JsonObject, ...], where, "cells")
    return tuple(_cell(cell, f"{where}: cells[{index}]") for index, cell in enumerate(cells))


def _cell(cell: dict, where: str) -> BenchmarkCell:
    for key in ("puzzle", "planner", "runs", "successes", "time_to_first"):
        if key not in cell:
            raise RecordError(f"{where}: missing key {key!r}")
    estimate = read_value(cell["time_to_first"], JsonObject | None, where, "time_to_first")
    median = None
    if estimate is not None:
        if "median" not in estimate:
            raise RecordError(f"{where}: time_to_first: missing key 'median'")
        median = read_value(estimate["median"], float | None, f"{where}: time_to_first", "median")
    return BenchmarkCell(read_value(cell["puzzle"], str, where, "puzzle"),
                         read_value(cell["planner"], str, where, "planner"),
                         read_value(cell["runs"], Count, where, "runs"),
                         read_value(cell["successes"], Count, where, "successes"), median)
