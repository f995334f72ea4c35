"""The four benchmark planners by name, behind one interface.

``get_planner(name).plan(problem, time_limit, seed)`` -> :class:`~solver.planning.PlanResult`
(best path, action cost, first-solution time, cost over time). Every planner
scores paths with :func:`solver.actions.count_actions` and runs until its
time limit (all four are anytime). Planners marked ``uses_ompl_rng`` draw
from OMPL's global RNG too: run each of their runs in a fresh process that
seeded it with the run's seed (:func:`solver.validation.seed_ompl`), as
:mod:`solver.benchmark` does.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from .planning import PlanResult
from .pool import stable_seed
from .problem import Problem

PlanFunction = Callable[..., PlanResult]


@dataclass(frozen=True)
class PlannerSpec:
    name: str  # registry id, e.g. "la_rrt"
    title: str  # the name in logs and plots, e.g. "LA-RRT"
    plan_function: PlanFunction
    uses_ompl_rng: bool

    def plan(self, problem: Problem, time_limit: float, seed: int, progress_interval: float = 0.1) -> PlanResult:
        """Run for ``time_limit`` seconds; ``seed`` drives every random draw of this planner."""
        if not time_limit > 0:
            raise ValueError(f"time_limit must be a positive number of seconds, got {time_limit!r}")
        if not progress_interval > 0:
            raise ValueError(f"progress_interval must be positive seconds, got {progress_interval!r}")
        return self.plan_function(problem, time_limit, seed, progress_interval)


def _la_rrt(*args) -> PlanResult:
    from .la_rrt import plan_la_rrt

    return plan_la_rrt(*args)


def _rrt_star(*args) -> PlanResult:
    from .ompl_planners import plan_rrt_star

    return plan_rrt_star(*args)


def _lbt_rrt(*args) -> PlanResult:
    from .lbt_rrt import plan_lbt_rrt

    return plan_lbt_rrt(*args)


def _bit_star(*args) -> PlanResult:
    from .ompl_planners import plan_bit_star

    return plan_bit_star(*args)


PLANNERS: dict[str, PlannerSpec] = {
    spec.name: spec
    for spec in (
        PlannerSpec("la_rrt", "LA-RRT", _la_rrt, uses_ompl_rng=False),
        PlannerSpec("rrt_star", "RRT*", _rrt_star, uses_ompl_rng=True),
        PlannerSpec("lbt_rrt", "LBT-RRT", _lbt_rrt, uses_ompl_rng=False),
        PlannerSpec("bit_star", "BIT*", _bit_star, uses_ompl_rng=True),
    )
}
"""The paper's four planners, in the paper's order."""


def get_planner(name: str) -> PlannerSpec:
    try:
        return PLANNERS[name]
    except KeyError:
        raise ValueError(f"unknown planner {name!r}; valid: {', '.join(PLANNERS)}") from None


def plan(name: str, problem: Problem, time_limit: float, seed: int, progress_interval: float = 0.1) -> PlanResult:
    """Run the planner registered as ``name``."""
    return get_planner(name).plan(problem, time_limit, seed, progress_interval)


def run_seed(planner: str, puzzle: str, run: int, base_seed: int = 0) -> int:
    """The seed of run ``run`` of ``planner`` on ``puzzle``: stable across machines, orders and processes."""
    return stable_seed("run", base_seed, planner, puzzle, run)
