"""The benchmark planners by name, behind one interface.

``get_planner(name).plan(problem, time_limit, seed)`` -> :class:`~solver.planning.anytime.PlanResult`
(best path, action cost, first-solution time, cost over time). Every planner
scores paths with :func:`phyrogen_core.actions.count_actions`, runs until its time
limit (all are anytime) or, with ``until_first``, until its first solution
that holds at fine resolution, and takes its goal states from the shared
goal sampler (:mod:`solver.planning.goal_sampling`) seeded with ``goal_seed``: the
benchmark gives every planner of a run the same one. Planners marked
``uses_ompl_rng`` draw from OMPL's global RNG too: run each of their runs in
a fresh process that seeded it with the run's seed
(:func:`solver.planning.ompl_setup.seed_ompl`), as :mod:`solver.benchmark.runner` does.

The entries, in the order of logs, tables and plots:

- ``la_rrt`` "LA-RRT": the paper's LA-RRT (:data:`solver.planning.la_rrt.PAPER_SETTINGS`);
- ``la_rrt_push`` "LA-RRT+push (ours)": our LA-RRT with blocker pushes and the
  other additions of :mod:`solver.planning.la_rrt` (:data:`solver.planning.la_rrt.PUSH_SETTINGS`);
- ``rrt_star`` "RRT*", ``lbt_rrt`` "LBT-RRT", ``bit_star`` "BIT*".

Each entry has a ``version``: the benchmark journal keys runs by it, so a run
recorded before a planner's code or settings changed is run again, not
reused. Bump the code part by hand when a planner's code changes; its
settings and the goal sampler's are digested into it.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

from phyrogen_core.seeding import stable_seed
from solver.planning.anytime import PlanResult
from solver.planning.goal_sampling import DEFAULT_GOAL_SETTINGS, default_goal_seed
from solver.planning.la_rrt import PAPER_SETTINGS, PUSH_SETTINGS, LaRrtSettings
from solver.planning.problem import Problem

PlanFunction = Callable[..., PlanResult]


@dataclass(frozen=True)
class PlannerSpec:
    name: str  # registry id, e.g. "la_rrt"
    title: str  # the name in logs and plots, e.g. "LA-RRT"
    plan_function: PlanFunction
    uses_ompl_rng: bool
    version: str = "1"  # changes whenever the planner's code or settings do (see the module docstring)

    def plan(self, problem: Problem, time_limit: float, seed: int, progress_interval: float = 0.1,
             until_first: bool = False, goal_seed: int | None = None) -> PlanResult:
        """Run for ``time_limit`` seconds (or until the first solution when ``until_first``); ``seed``
        drives the planner's own random draws, ``goal_seed`` the shared goal sampler (default: from
        ``seed``)."""
        if not time_limit > 0:
            raise ValueError(f"time_limit must be a positive number of seconds, got {time_limit!r}")
        if not progress_interval > 0:
            raise ValueError(f"progress_interval must be positive seconds, got {progress_interval!r}")
        goal_seed = default_goal_seed(seed) if goal_seed is None else goal_seed
        return self.plan_function(problem, time_limit, seed, progress_interval, bool(until_first), goal_seed)


def _la_rrt(settings: LaRrtSettings, title: str, problem, time_limit, seed, progress_interval, until_first,
            goal_seed) -> PlanResult:
    from solver.planning.la_rrt import plan_la_rrt

    return plan_la_rrt(problem, time_limit, seed, progress_interval, settings, until_first=until_first,
                       goal_seed=goal_seed, title=title)


def _rrt_star(*args) -> PlanResult:
    from solver.planning.ompl_planners import plan_rrt_star

    return plan_rrt_star(*args)


def _lbt_rrt(problem, time_limit, seed, progress_interval, until_first, goal_seed) -> PlanResult:
    from solver.planning.lbt_rrt import plan_lbt_rrt

    return plan_lbt_rrt(problem, time_limit, seed, progress_interval, until_first=until_first, goal_seed=goal_seed)


def _bit_star(*args) -> PlanResult:
    from solver.planning.ompl_planners import plan_bit_star

    return plan_bit_star(*args)


def _version(code: str, settings: object = None) -> str:
    """``code`` (bumped by hand), a digest of ``settings`` (a frozen dataclass) and the goal sampler's tag."""
    parts = [code]
    if settings is not None:
        parts.append(hashlib.sha256(repr(settings).encode()).hexdigest()[:8])
    parts.append(DEFAULT_GOAL_SETTINGS.tag)
    return "/".join(parts)


def _registry() -> dict[str, PlannerSpec]:
    specs = (
        PlannerSpec("la_rrt", "LA-RRT", partial(_la_rrt, PAPER_SETTINGS, "LA-RRT"), False,
                    _version("paper-2", PAPER_SETTINGS)),
        PlannerSpec("la_rrt_push", "LA-RRT+push (ours)", partial(_la_rrt, PUSH_SETTINGS, "LA-RRT+push (ours)"),
                    False, _version("push-3", PUSH_SETTINGS)),
        PlannerSpec("rrt_star", "RRT*", _rrt_star, True, _version("ompl-3")),
        PlannerSpec("lbt_rrt", "LBT-RRT", _lbt_rrt, False, _version("py-3")),
        PlannerSpec("bit_star", "BIT*", _bit_star, True, _version("ompl-3")),
    )
    return {spec.name: spec for spec in specs}


PLANNERS: dict[str, PlannerSpec] = _registry()
"""The paper's four planners, in the paper's order, with our LA-RRT variant after the paper's."""

LA_RRT_PLANNERS = ("la_rrt", "la_rrt_push")
"""The entries whose best path is saved into the puzzle folder (the manipulation stage's input)."""


def get_planner(name: str) -> PlannerSpec:
    try:
        return PLANNERS[name]
    except KeyError:
        raise ValueError(f"unknown planner {name!r}; valid: {', '.join(PLANNERS)}") from None


def plan(name: str, problem: Problem, time_limit: float, seed: int, progress_interval: float = 0.1,
         until_first: bool = False, goal_seed: int | None = None) -> PlanResult:
    """Run the planner registered as ``name``."""
    return get_planner(name).plan(problem, time_limit, seed, progress_interval, until_first, goal_seed)


def run_seed(planner: str, puzzle: str, run: int, base_seed: int = 0) -> int:
    """The seed of run ``run`` of ``planner`` on ``puzzle``: stable across machines, orders and processes."""
    return stable_seed("run", base_seed, planner, puzzle, run)
