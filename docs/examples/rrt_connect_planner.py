"""The worked example of docs/adding-a-planner.md: OMPL's RRT-Connect as a benchmark planner.

:func:`~solver.planning.ompl_planners.ompl_plan_function` wraps the ``ompl.geometric`` class with
what every OMPL entry shares: our state and motion validity checks (counted for check budgets),
the run's shared goal sampler, the action-bound objective, anytime recording with the
fine-resolution check and restarts after a clipped path. RRT-Connect is not asymptotically optimal:
it keeps connecting its two trees, and a connection that needs fewer actions is kept.
"""

from ompl import geometric as og

from solver.planning.ompl_planners import ompl_plan_function
from solver.planning.registry import Planner, planner


@planner
class RrtConnect(Planner):
    name, title, version = "rrt_connect", "RRT-Connect", "ompl-1"
    uses_ompl_rng = True
    summary = "OMPL's RRT-Connect (not optimizing); the cheapest of its connections"
    plan = staticmethod(ompl_plan_function("RRT-Connect", og.RRTConnect))
