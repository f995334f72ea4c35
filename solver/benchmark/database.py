"""The benchmark database read back as typed runs, for the summary table and the results page.

The database is the one OMPL's ``readBenchmarkLog`` built from our logs (Planner Arena's schema):
``experiments`` (one per puzzle, with its time limit), ``plannerConfigs`` (a planner's name and
its common properties as text: ``until_first``, ``budget_checks``, ``version``), ``runs`` (one
column per run property of :data:`solver.benchmark.ompl_log.RUN_PROPERTIES`) and ``progress``.
Columns added to the run properties over time (``collision_checks``, ``checks_to_first_solution``,
``end_reason``) may be missing from an older database; they read as None.
Anything else (a missing file, a file that is not SQLite, a database without those tables or
without runs) is refused with :class:`BenchmarkDataError`, one line naming the file.
"""

from __future__ import annotations

import contextlib
import re
import sqlite3
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from solver.planning.registry import PLANNERS

DATABASE = "benchmark.db"
"""The database's name in a benchmark's output folder."""


class BenchmarkDataError(ValueError):
    """A benchmark database that is missing or cannot be read as one: bad input, found before anything is written."""


@dataclass(frozen=True)
class DatabaseRun:
    """One run as the database holds it."""

    experiment: str
    planner: str
    solved: bool
    time: float
    first_solution_time: float | None
    action_cost: int | None
    checks: int | None  # None in databases (or runs) from before collision checks were recorded
    until_first: bool  # the run stopped at its first solution: its checks are those to the first solution
    budget_checks: int | None
    first_solution_checks: int | None = None  # run property "checks to first solution", where recorded
    end: str | None = None  # run property "end reason" (solver.planning.anytime.END_REASONS), where recorded
    budget_cpu: float | None = None  # the runs' CPU-seconds budget (machine-dependent), where they had one

    @property
    def clock_ended(self) -> bool:
        """The wall-clock backstop, not the budget, ended this run: it is no result of its budget."""
        return self.end == "clock"

    @property
    def checks_to_first_solution(self) -> int | None:
        """Collision checks spent up to the first solution: the run's own count where it recorded one,
        else all its checks if it stopped there (``until_first``), else unknown (None)."""
        if not self.solved:
            return None
        if self.first_solution_checks is not None:
            return self.first_solution_checks
        return self.checks if self.until_first else None


@dataclass(frozen=True)
class BenchmarkData:
    """A benchmark database's experiments (puzzles), planners and runs."""

    path: Path
    experiments: tuple[str, ...]  # in the order they were written
    time_limits: Mapping[str, float]
    planners: tuple[str, ...]  # in the registry's order, unknown ones after, by name
    runs: tuple[DatabaseRun, ...]
    setup: str  # the first experiment's setup text (profile, mode, planners)

    def cell(self, experiment: str, planner: str) -> list[DatabaseRun]:
        return [r for r in self.runs if r.experiment == experiment and r.planner == planner]


def planner_key(name: str) -> tuple[int, str]:
    """Sort key: the live registry's order (a planner registered late sorts in place), others after by name."""
    order = [spec.title for spec in PLANNERS.values()]
    return (order.index(name) if name in order else len(order), name)


_SETTING = re.compile(r"^\s*;?\s*(\S+) (\S+) = (.*?)\s*;?\s*$")


def parse_settings(text: str | None) -> dict[str, str]:
    """A planner config's common properties (``name TYPE = value`` lines, as OMPL stores them) by name."""
    out = {}
    for line in (text or "").splitlines():
        match = _SETTING.match(line)
        if match:
            out[match.group(1)] = match.group(3)
    return out


def _whole_or_none(text: str | None) -> int | None:
    try:
        return int(text) if text is not None else None
    except ValueError:
        return None


def _number_or_none(text: str | None) -> float | None:
    try:
        return float(text) if text is not None else None
    except ValueError:
        return None


def _end_reason(value: object) -> str | None:
    from solver.planning.anytime import END_REASONS

    if isinstance(value, int) and 0 <= value < len(END_REASONS):
        return END_REASONS[value]
    return None


def read_benchmark(db_path: str | Path) -> BenchmarkData:
    """Read ``db_path`` (a ``benchmark.db``); raise :class:`BenchmarkDataError` when it is not one."""
    path = Path(db_path)
    if not path.is_file():
        raise BenchmarkDataError(f"{path}: no benchmark database here (a finished `phyrogen benchmark --out DIR` "
                                 f"writes DIR/{DATABASE})")
    try:
        # Read-only: a report never changes the database it reads.
        with contextlib.closing(sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)) as db:
            columns = {row[1] for row in db.execute("PRAGMA table_info(runs)")}
            required = {"experimentid", "plannerid", "solved", "time", "time_to_first_solution", "action_cost"}
            if not required <= columns:
                missing = ", ".join(sorted(required - columns))
                raise BenchmarkDataError(f"{path}: not a PhyRoGen benchmark database (its runs table lacks {missing})")
            checks = "runs.collision_checks" if "collision_checks" in columns else "NULL"
            first_checks = "runs.checks_to_first_solution" if "checks_to_first_solution" in columns else "NULL"
            end = "runs.end_reason" if "end_reason" in columns else "NULL"
            experiments = db.execute("SELECT name, timelimit, setup FROM experiments ORDER BY id").fetchall()
            rows = db.execute(
                f"""SELECT experiments.name, plannerConfigs.name, plannerConfigs.settings, runs.solved, runs.time,
                           runs.time_to_first_solution, runs.action_cost, {checks}, {first_checks}, {end}
                    FROM runs JOIN experiments ON runs.experimentid = experiments.id
                              JOIN plannerConfigs ON runs.plannerid = plannerConfigs.id
                    ORDER BY runs.id""").fetchall()
    except sqlite3.Error as exc:
        raise BenchmarkDataError(f"{path}: not a readable benchmark database ({exc})") from None
    if not rows:
        raise BenchmarkDataError(f"{path}: the benchmark database holds no runs")
    runs = []
    for experiment, planner, settings, solved, seconds, first, cost, spent, spent_first, end in rows:
        properties = parse_settings(settings)
        if seconds is None:
            raise BenchmarkDataError(f"{path}: a run of {planner} on {experiment} has no time")
        runs.append(DatabaseRun(experiment, planner, bool(solved), float(seconds),
                                None if first is None else float(first), None if cost is None else int(cost),
                                None if spent is None else int(spent), properties.get("until_first") == "1",
                                _whole_or_none(properties.get("budget_checks")),
                                None if spent_first is None else int(spent_first), _end_reason(end),
                                _number_or_none(properties.get("budget_cpu"))))
    names = tuple(dict.fromkeys(name for name, _, _ in experiments if any(r.experiment == name for r in runs)))
    limits = {name: float(limit) for name, limit, _ in experiments}
    planners = tuple(sorted({r.planner for r in runs}, key=planner_key))
    return BenchmarkData(path, names, limits, planners, tuple(runs), experiments[0][2] or "")
