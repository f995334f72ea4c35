"""How much a benchmark runs: profiles (runs per planner and puzzle, seconds per run for each
generator), the budget per run (collision checks or CPU seconds) and the wall-clock backstop that
goes with a budget."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from phyrogen_core.registry import benchmark_time_limits

PAPER_TIME_LIMITS: Mapping[str, float] = benchmark_time_limits("paper")
"""Seconds per run for each generator's puzzles, as in the paper (from the generator registry)."""


@dataclass(frozen=True)
class Profile:
    """How much to run: runs per (planner, puzzle) and seconds per run for each generator."""

    name: str
    runs: int
    time_limits: Mapping[str, float]
    progress_interval: float
    default_time_limit: float | None = None  # for a generator missing from time_limits (one limit for all)

    def time_limit(self, generator: str) -> float:
        if generator in self.time_limits:
            return self.time_limits[generator]
        if self.default_time_limit is not None:
            return self.default_time_limit
        raise ValueError(f"profile {self.name!r} has no time limit for generator {generator!r}; "
                         f"it has: {', '.join(self.time_limits)} (or give one limit for all: --time-limit)")


QUICK_TIME_LIMITS: Mapping[str, float] = benchmark_time_limits("quick")
"""About a tenth of the paper's limits, from the generator registry (docs/generators.md says
why Move N Times and Lockbox Random differ)."""

PROFILES: Mapping[str, Profile] = {
    "paper": Profile("paper", 100, PAPER_TIME_LIMITS, 0.5),
    "quick": Profile("quick", 10, QUICK_TIME_LIMITS, 0.1),
}


def get_profile(name: str, runs: int | None = None, time_limit: float | None = None) -> Profile:
    """A registered profile, optionally with another run count or one time limit for every generator."""
    try:
        profile = PROFILES[name]
    except KeyError:
        raise ValueError(f"unknown profile {name!r}; valid: {', '.join(PROFILES)}") from None
    if runs is not None:
        if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
            raise ValueError(f"runs must be a whole number of at least 1, got {runs!r}")
        profile = Profile(profile.name, runs, profile.time_limits, profile.progress_interval)
    if time_limit is not None:
        check_time_limit(time_limit)
        limit = float(time_limit)
        # The one limit holds for every generator, registered or not (a hand-made puzzle's too).
        profile = Profile(f"{profile.name}-{limit:g}s", profile.runs, {g: limit for g in profile.time_limits},
                          min(profile.progress_interval, limit / 20), default_time_limit=limit)
    return profile


def backstop_profile(profile: Profile, budget_checks: Budget = None, budget_cpu: float | None = None) -> Profile:
    """``profile`` with each generator's time limit replaced by the wall-clock backstop of its budget
    (:func:`solver.benchmark.difficulty.backstop_seconds`, :func:`~solver.benchmark.difficulty.cpu_backstop_seconds`):
    so wide that the budget, not the clock, ends a run on any machine under any load; a tighter one
    is an explicit choice (``--time-limit``). Without a budget, ``profile`` itself. (At the paper's
    limits themselves, the clock ended 31 of 34 unsolved runs on a loaded 2-core machine.)"""
    from solver.benchmark.difficulty import backstop_seconds, cpu_backstop_seconds

    if budget_checks is None and budget_cpu is None:
        return profile
    if budget_cpu is not None:
        limits = {g: cpu_backstop_seconds(budget_cpu) for g in profile.time_limits}
        default = cpu_backstop_seconds(budget_cpu)
    elif isinstance(budget_checks, int):
        limits = {g: backstop_seconds(budget_checks) for g in profile.time_limits}
        default = backstop_seconds(budget_checks)
    else:
        limits = {g: backstop_seconds(budget_checks[g]) for g in profile.time_limits if g in budget_checks}
        default = None
    return Profile(f"{profile.name}-backstop", profile.runs, limits, profile.progress_interval,
                   default_time_limit=default)


def check_time_limit(seconds: object) -> None:
    """Raise ValueError unless ``seconds`` is a positive, finite number (an infinite run never ends)."""
    if isinstance(seconds, bool) or not isinstance(seconds, int | float) or not (0 < seconds < math.inf):
        raise ValueError(f"time limit must be a positive, finite number of seconds, got {seconds!r}")


def check_workers(workers: object) -> None:
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be a whole number of at least 1, got {workers!r}")


Budget = int | Mapping[str, int] | None
"""A check budget per run: one for every puzzle, one per generator (``--budget-from-paper``,
:mod:`solver.benchmark.paper_budgets`), or None (runs end on their time limit)."""


def budget_for(budget: Budget, generator: str) -> int | None:
    """The check budget of a run on ``generator``'s puzzles; ValueError when a per-generator budget
    has none for it."""
    if budget is None or isinstance(budget, int):
        return budget
    try:
        return budget[generator]
    except KeyError:
        raise ValueError(f"no check budget for generator {generator!r}; the budgets are for: "
                         f"{', '.join(budget)}") from None
