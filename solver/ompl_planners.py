"""RRT* and BIT* from OMPL, optimizing an action-cost objective on our collision model.

The paper's action cost (runs of moves of one object) is not additive over
path segments, which OMPL's objectives must be. The planners therefore
optimize its additive upper bound: each segment costs the number of objects
it moves. Every path a planner returns is scored with the true action count
(:func:`solver.actions.count_actions`) like every other planner's. Planners
are solved in short slices (OMPL keeps the tree between ``solve`` calls), so
the best cost can be sampled over time.

OMPL draws from its own global RNG, which must be seeded once in a fresh
process before the planner is built (see :mod:`solver.benchmark`); the goal
sampler draws from a numpy Generator seeded with the run's seed.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from ompl import base as ob
from ompl import geometric as og

from .planning import AnytimeRecorder, PlanResult, planning_steps
from .problem import Problem, problem_factors
from .validation import _GoalRegion, ompl_setup


class ObjectsMovedObjective(ob.OptimizationObjective):
    """Segment cost = number of objects (factors) whose joints it moves; states cost nothing."""

    def __init__(self, si, factors: list[list[int]], tolerance: float = 1e-6):
        super().__init__(si)
        self.factors = factors
        self.tolerance = tolerance
        self.setCostThreshold(ob.Cost(0.0))  # never satisfied: run until the time limit

    def stateCost(self, state) -> ob.Cost:  # noqa: N802 (OMPL's name)
        return ob.Cost(0.0)

    def motionCost(self, s1, s2) -> ob.Cost:  # noqa: N802
        moved = 0
        for columns in self.factors:
            for i in columns:
                if abs(s1[i] - s2[i]) > self.tolerance:
                    moved += 1
                    break
        return ob.Cost(float(moved))


class _BoundedGoalRegion(_GoalRegion):
    """The goal region with a finite number of goal samples: BIT* draws goal states
    until the region says no more, so an unbounded region never lets it start."""

    def maxSampleCount(self) -> int:  # noqa: N802 (OMPL's name)
        return 100


def _setup(problem: Problem, rng: np.random.Generator):
    """SpaceInformation and ProblemDefinition for ``problem`` with the action-bound objective."""
    si, pdef, validator, keep = ompl_setup(problem, planning_steps(problem), _BoundedGoalRegion, rng)
    objective = ObjectsMovedObjective(si, [list(c) for c in problem_factors(problem).values()])
    pdef.setOptimizationObjective(objective)
    # Python objects OMPL holds only by reference must outlive the run.
    return si, pdef, (keep, validator, objective)


def _solution(pdef, dimension: int) -> list[list[float]]:
    path = pdef.getSolutionPath()
    return [[path.getState(k)[i] for i in range(dimension)] for k in range(path.getStateCount())]


def _plan_ompl(name: str, make: Callable, problem: Problem, time_limit: float, seed: int,
               progress_interval: float) -> PlanResult:
    rng = np.random.default_rng(seed)
    si, pdef, _keep = _setup(problem, rng)
    planner = make(si)
    planner.setProblemDefinition(pdef)
    planner.setup()
    recorder = AnytimeRecorder(name, problem, time_limit, progress_interval)
    if not problem.model.is_valid(problem.start):
        return recorder.result(0, "Invalid start")
    dimension = len(problem.start)
    while not recorder.expired():
        slice_end = min(recorder.time_limit - recorder.elapsed(), progress_interval)
        planner.solve(ob.timedPlannerTerminationCondition(max(slice_end, 1e-3)))
        if pdef.hasExactSolution():
            recorder.offer(_solution(pdef, dimension))
        recorder.sample(planner.numIterations(), force=True)
    return recorder.result(planner.numIterations())


def plan_rrt_star(problem: Problem, time_limit: float, seed: int, progress_interval: float = 0.1) -> PlanResult:
    """OMPL's RRT* (default range and goal bias) for ``time_limit`` seconds."""
    return _plan_ompl("RRT*", og.RRTstar, problem, time_limit, seed, progress_interval)


def plan_bit_star(problem: Problem, time_limit: float, seed: int, progress_interval: float = 0.1) -> PlanResult:
    """OMPL's BIT* (default batch size) for ``time_limit`` seconds."""
    return _plan_ompl("BIT*", og.BITstar, problem, time_limit, seed, progress_interval)
