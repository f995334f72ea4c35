"""A puzzle's difficulty in machine-independent units: a reference planner's success rate and checks.

``measure_difficulty`` runs the reference planner (OMPL's BIT*, from the
planner registry) ``runs`` times on the puzzle, each run ended at its first
solution that holds at fine resolution or after ``budget_checks`` collision
checks, and reports how many runs succeeded (with the rate's 95 % Wilson
interval, :func:`solver.benchmark.statistics.wilson_interval`) and the median checks to the first
solution among the successes
(:class:`phyrogen_core.difficulty.Difficulty`).

Run ``r`` is seeded exactly as run ``r`` of ``phyrogen benchmark --planners
bit_star --until first --budget-checks N`` on the same puzzle (the planner's
seed and the shared goal sampler's seed from the puzzle's name and the run
index, :func:`solver.planning.registry.run_seed`, :func:`solver.planning.goal_sampling.goal_seed`,
OMPL's global RNG re-seeded before each run), so the two agree run for run.
Nothing here reads the clock to decide anything: the same puzzle, run count
and budget give the same numbers on any machine under any load. The clock is
only a backstop against a planner that stops checking; a run that reaches it
makes the measurement fail (:class:`DifficultyError`) rather than depend on
the machine.
"""

from __future__ import annotations

import statistics
from dataclasses import dataclass

from phyrogen_core.chain import KinematicChain
from phyrogen_core.difficulty import Difficulty
from phyrogen_core.puzzle import Goal
from solver.benchmark.statistics import wilson_interval
from solver.planning.anytime import BACKSTOP_SECONDS, PlanResult, backstop_seconds, check_budget_checks
from solver.planning.goal_sampling import goal_seed
from solver.planning.registry import get_planner, run_seed

REFERENCE_PLANNER = "bit_star"
"""The registry name of the planner whose runs measure difficulty."""
DEFAULT_RUNS = 8
"""Runs per puzzle by default (``--difficulty-runs``)."""
DEFAULT_BUDGET_CHECKS = 1_000_000
"""Collision checks per run by default (``--difficulty-checks``), a motion charged by its length in
resolution steps, as every benchmark run is: cheap enough to measure every puzzle of a dataset (BIT* at
most about 10 CPU s a run, on Lockbox Random), and large enough that the paper's easy puzzles are solved
(BIT* 23 of 24 runs on seeds 1-2 of the six generators, where 20,000, the default while a motion counted
once, left 17 of the 24 unsolved); the hard suite's budgets are the paper's (:mod:`phyrogen_core.suites`)."""
MAX_RUNS = 10_000


class DifficultyError(RuntimeError):
    """The measurement would depend on the machine (a run ended on its wall-clock backstop)."""


@dataclass(frozen=True)
class DifficultySettings:
    """What to measure: ``runs`` runs of ``planner``, each of at most ``budget_checks`` checks."""

    runs: int = DEFAULT_RUNS
    budget_checks: int = DEFAULT_BUDGET_CHECKS
    planner: str = REFERENCE_PLANNER

    def __post_init__(self) -> None:
        if isinstance(self.runs, bool) or not isinstance(self.runs, int) or not 1 <= self.runs <= MAX_RUNS:
            raise ValueError(f"difficulty runs must be a whole number from 1 to {MAX_RUNS}, got {self.runs!r}")
        check_budget_checks(self.budget_checks)
        get_planner(self.planner)  # an unknown name is refused here, naming the valid ones


BACKSTOP_CPU_FACTOR = 20.0
"""The wall-clock backstop of a run budgeted in CPU seconds: this many times its budget (a process
given a twentieth of a core still spends its budget first), and at least :data:`BACKSTOP_SECONDS`."""


def cpu_backstop_seconds(budget_cpu: float) -> float:
    """The wall-clock backstop of a run of ``budget_cpu`` CPU seconds (:data:`BACKSTOP_CPU_FACTOR`)."""
    return max(BACKSTOP_SECONDS, BACKSTOP_CPU_FACTOR * float(budget_cpu))


def difficulty_run(chain: KinematicChain, goal: Goal, name: str, run: int, settings: DifficultySettings) -> PlanResult:
    """Run ``run`` of the measurement on the puzzle ``name`` (seeded as the benchmark's run ``run``)."""
    from solver.planning.problem import problem_for_chain
    from solver.planning.solve import seeded_plan

    problem = problem_for_chain(chain, goal)
    return seeded_plan(get_planner(settings.planner), problem, run_seed(settings.planner, name, run),
                       goal_seed(name, run), backstop_seconds(settings.budget_checks), 1.0, True,
                       settings.budget_checks)


def summarize(results: list[PlanResult], settings: DifficultySettings) -> Difficulty:
    """The difficulty of a puzzle from its measurement runs (in run order)."""
    backstop = backstop_seconds(settings.budget_checks)
    for run, result in enumerate(results):
        if not result.solved and result.checks < settings.budget_checks and result.time >= backstop:
            raise DifficultyError(f"difficulty run {run} ended on its {backstop:g} s backstop after "
                                  f"{result.checks} of {settings.budget_checks} checks; the measurement "
                                  "would depend on the machine")
    checks = [result.checks for result in results if result.solved]
    interval = wilson_interval(len(checks), len(results))  # the benchmark's own (solver.benchmark.statistics)
    return Difficulty(settings.planner, get_planner(settings.planner).version, len(results), settings.budget_checks,
                      len(checks), interval.low, interval.high,
                      float(statistics.median(checks)) if checks else None)


def measure_difficulty(chain: KinematicChain, goal: Goal, name: str,
                       settings: DifficultySettings | None = None) -> Difficulty:
    """The difficulty of the puzzle ``name`` (its chain and goal), in this process, run after run."""
    settings = DifficultySettings() if settings is None else settings
    return summarize([difficulty_run(chain, goal, name, run, settings) for run in range(settings.runs)], settings)
