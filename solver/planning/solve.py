"""The solve stage: one seeded run of a registered planner on a puzzle, in this process, its path in memory.

:func:`solve` takes a puzzle (read from its folder or just generated), a planner's registry name, a
budget of collision checks and a run index, and returns a :class:`SolvedPath`. It writes nothing:
saving a best path into ``solutions/`` is the benchmark's business alone
(:mod:`solver.benchmark.solutions`). A run is seeded exactly as run ``run`` of ``phyrogen benchmark
--budget-checks N`` on the same puzzle is (:func:`seeded_plan`, which the benchmark's workers run
too): the same puzzle, planner, budget and run give the same path here, in a benchmark and on any
machine under any load; the clock is only a backstop against a planner that stops checking
(:func:`~solver.planning.anytime.backstop_seconds`). That holds for the OMPL planners too since
``ompl-6``: before, a goal state handed out again put a second vertex on the first, and OMPL orders
neighbours at equal distances by memory address, so RRT*'s checks and iterations could differ between
fresh processes (:mod:`solver.planning.ompl_planners`, ``REPEAT_OFFSET``; tests/test_budget_processes.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from phyrogen_core.stage_records.certify import PlannerRun
from solver.planning.anytime import backstop_seconds, check_budget_checks
from solver.planning.goal_sampling import goal_seed
from solver.planning.registry import PlannerSpec, get_planner, run_seed

if TYPE_CHECKING:
    from phyrogen_core.export import LoadedPuzzle
    from solver.planning.anytime import PlanResult
    from solver.planning.problem import Problem


@dataclass(frozen=True)
class SolvedPath(PlannerRun):
    """One solve run's outcome: the path (every joint of ``joint_order``; empty when unsolved) and
    what identifies the run (the fields the certify stage's result shares, and these)."""

    version: str
    """The planner's version, as the benchmark's journal keys its runs."""
    seed: int
    length: float | None


def seeded_plan(spec: PlannerSpec, problem: Problem, seed: int, goal_seed: int, time_limit: float,
                progress_interval: float = 1.0, until_first: bool = False, budget_checks: int | None = None,
                budget_cpu: float | None = None) -> PlanResult:
    """Run ``spec`` on ``problem`` with ``seed``: a planner that draws from OMPL's global RNG gets it
    seeded first (:func:`~solver.planning.ompl_setup.seed_ompl`), so that the run draws the same
    numbers in any process, whatever ran there before."""
    if spec.uses_ompl_rng:
        from solver.planning.ompl_setup import seed_ompl

        seed_ompl(seed)
    return spec.plan(problem, time_limit, seed, progress_interval, until_first, goal_seed, budget_checks, budget_cpu)


def solve(puzzle: LoadedPuzzle, planner: str, budget_checks: int, run: int = 0, base_seed: int = 0) -> SolvedPath:
    """Run ``planner`` (a registry name) on ``puzzle`` for ``budget_checks`` collision checks, seeded as
    the benchmark's run ``run`` (with ``base_seed``). ValueError for an unknown planner or a budget
    that is not a whole number in 1..:data:`~solver.planning.anytime.MAX_BUDGET_CHECKS`."""
    from solver.planning.problem import chain_path, problem_for_chain

    if budget_checks is None:
        raise ValueError("a solve run needs a budget of collision checks (a clock would make it machine-dependent)")
    check_budget_checks(budget_checks)
    if isinstance(run, bool) or not isinstance(run, int) or run < 0:
        raise ValueError(f"run must be a whole number of at least 0, got {run!r}")
    spec = get_planner(planner)
    seed = run_seed(planner, puzzle.name, run, base_seed)
    problem = problem_for_chain(puzzle.chain, puzzle.goal)
    result = seeded_plan(spec, problem, seed, goal_seed(puzzle.name, run, base_seed), backstop_seconds(budget_checks),
                         budget_checks=budget_checks)
    solved = result.solved
    return SolvedPath(puzzle.name, planner, spec.title, run, budget_checks, solved, result.checks, result.end,
                      tuple(puzzle.joint_order), chain_path(problem, result.path) if solved else (),
                      result.action_cost if solved else None, version=spec.version, seed=seed,
                      length=result.length if solved else None)
