"""The built-in benchmark planners, each a :class:`~solver.planning.registry.Planner` plug-in.

They are declared in PhyRoGen's own ``pyproject.toml`` (``[project.entry-points."phyrogen.planners"]``)
exactly as a planner of another package is declared in its own, and registered, in this order (the
order of logs, tables and plots), when the registry first loads them. Names, titles and versions are
the journal's keys: see :mod:`solver.planning.registry`. Plan code is imported only when a planner
runs or a version is first asked for, so that building the command line's parser stays light.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from solver.planning.registry import Planner, planner

if TYPE_CHECKING:
    from solver.planning.anytime import PlanResult


class _Imported(Planner):
    """A planner whose plan function, ``function`` of ``module``, is imported only when it first runs; it
    is called with the registry's arguments by keyword (each plan function orders its own optional ones),
    and with :meth:`options`."""

    module = "solver.planning.ompl_planners"
    function = "plan_rrt_star"

    def options(self) -> dict[str, object]:
        """The plan function's keyword arguments of this planner's own."""
        return {}

    def plan(self, problem, time_limit, seed, progress_interval, until_first, goal_seed, budget_checks=None,
             budget_cpu=None) -> PlanResult:
        plan = getattr(importlib.import_module(self.module), self.function)
        return plan(problem, time_limit, seed, progress_interval, until_first=until_first, goal_seed=goal_seed,
                    budget_checks=budget_checks, budget_cpu=budget_cpu, **self.options())


class _LaRrtBase(_Imported):
    """LA-RRT under one of :mod:`solver.planning.la_rrt`'s settings (named by ``which``)."""

    module, function = "solver.planning.la_rrt", "plan_la_rrt"
    which = "paper"
    version = "paper-4"
    saves_solution = True

    def settings(self) -> object:
        from solver.planning import la_rrt

        return {"paper": la_rrt.PAPER_SETTINGS, "push": la_rrt.PUSH_SETTINGS,
                "fixed_order": la_rrt.FIXED_ORDER_SETTINGS, "segment_check": la_rrt.SEGMENT_CHECK_SETTINGS}[self.which]

    def options(self) -> dict[str, object]:
        return {"settings": self.settings(), "title": self.title}


@planner
class LaRrt(_LaRrtBase):
    name, title = "la_rrt", "LA-RRT"
    summary = "the paper's LA-RRT; fewest actions, by path defragmentation"


@planner
class LaRrtPush(_LaRrtBase):
    name, title, which, version = "la_rrt_push", "LA-RRT+push (ours)", "push", "push-5"
    summary = "our LA-RRT with blocker pushes; fewest actions, by path defragmentation"


class _OmplBase(_Imported):
    """An OMPL planner of :mod:`solver.planning.ompl_planners`, by its plan function's name."""

    # ompl-6: a goal state handed out again is moved by a hair (ompl_planners.REPEAT_OFFSET), so that
    # a run's checks are the same in every process.
    version, uses_ompl_rng = "ompl-6", True


@planner
class RrtStar(_OmplBase):
    name, title = "rrt_star", "RRT*"
    summary = "OMPL's RRT*; objects moved per edge"


@planner
class LbtRrt(_Imported):
    name, title, version = "lbt_rrt", "LBT-RRT", "py-4"
    module, function = "solver.planning.lbt_rrt", "plan_lbt_rrt"
    summary = "LBT-RRT in Python; objects moved per edge, epsilon 0.4"


@planner
class BitStar(_OmplBase):
    name, title, function = "bit_star", "BIT*", "plan_bit_star"
    summary = "OMPL's BIT*; objects moved per edge"


# The ablations of ``la_rrt`` (docs/benchmark/README.md, "Ablations"): each switches one of its two
# behaviour changes back to the original's; outside ``--planners all``, so that "all" still means the
# five entries it meant before.
@planner
class LaRrtSegmentCheck(_LaRrtBase):
    name, title, which, group = "la_rrt_segment_check", "LA-RRT, original segment check", "segment_check", "ablations"
    saves_solution = False
    summary = "la_rrt that also checks the straight segment a step replaces by its staircase (ablation)"


@planner
class LaRrtFixedOrder(_LaRrtBase):
    name, title, which, group = "la_rrt_fixed_order", "LA-RRT, fixed factor order", "fixed_order", "ablations"
    saves_solution = False
    summary = "la_rrt whose factors move in the original's fixed order (ablation)"
