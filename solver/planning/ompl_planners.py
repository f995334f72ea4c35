"""RRT* and BIT* from OMPL, optimizing an action-cost objective on our collision model.

The paper's action cost (runs of moves of one object) is not additive over
path segments, which OMPL's objectives must be. The planners therefore
optimize its additive upper bound: each segment costs the number of objects
it moves. Every path a planner returns is scored with the true action count
(:func:`phyrogen_core.actions.count_actions`) like every other planner's. Planners
are solved in short slices (OMPL keeps the tree between ``solve`` calls), so
the best cost can be sampled over time; a slice ends early at the planner's
first solution, whose time and checks are measured then (not rounded up to
the slice's end); with ``until_first`` a run ends at
its first solution that holds at fine resolution (a first path that clips at
fine resolution restarts the planner; see :func:`run_ompl`).

Goal states come from the run's shared goal sampler
(:mod:`solver.planning.goal_sampling`) through :class:`SharedGoalRegion`, which hands
out only valid goal states. The two planners use it differently:

- BIT* draws goal states through OMPL's ``PlannerInputStates`` until their
  count reaches ``maxSampleCount()``, validity-checks each and makes every
  valid one a goal vertex; while it has none, it waits (sleeping) for the
  region until the termination condition. Our region's count is the
  sampler's capacity, so BIT* takes all of its states, the first one at
  once; with the old region (uniform goal states, at most 100), a lockbox
  or Simple Slider 3-4 gave it no valid one and it made no iteration.
- RRT* calls ``sampleGoal`` directly for its goal bias (5 % of its samples)
  whenever ``canSample()`` (``maxSampleCount() > 0``) and steers toward the
  state; it reaches the goal by ``isSatisfied``. After the sampler's states
  run out, the region hands out one of them again, moved by a hair
  (:data:`REPEAT_OFFSET`).

No goal sample is the same state as an earlier one. OMPL 2.0.1's nearest-neighbour
structure (GNAT) orders neighbours at equal distances by the memory address where it
keeps them, which differs between processes; a goal state handed out again used to put
a second vertex exactly on the first, and RRT* then checked a varying number of
zero-length motions between such twins (RRT* on Simple Slider 1: 100,000 or 100,027
checks, 3,329 or 3,330 iterations, in fresh processes with the same seed). Distinct
states have no equal distances but by a coincidence of measure zero, so the order, and
with it the checks, iterations, cost and path, are the same in every process.

OMPL draws from its own global RNG, which must be seeded once in a fresh
process before the planner is built (see :mod:`solver.benchmark.runner`); the goal
sampler and the region's repeats draw from numpy Generators seeded with the
run's goal seed and seed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from ompl import base as ob
from ompl import geometric as og

from solver.planning.anytime import AnytimeRecorder, Offer, PlanResult, count_checks, planning_steps
from solver.planning.goal_sampling import GoalSampler, default_goal_seed
from solver.planning.ompl_setup import ompl_setup
from solver.planning.problem import Problem, goal_distance, problem_factors


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


REPEAT_OFFSET = 1e-9
"""A goal state handed out again has each joint the goal leaves free moved by up to this share of its
range (uniform, within its limits), so that it is never the state it repeats (see the module docstring)."""


class SharedGoalRegion(ob.GoalSampleableRegion):
    """The goal region (target joints at their goal values) whose samples are the run's shared
    valid goal states (see the module docstring for how BIT* and RRT* use it)."""

    def __init__(self, si, problem: Problem, goals: GoalSampler, rng: np.random.Generator):
        super().__init__(si)
        self.problem = problem
        self.goals = goals
        self.rng = rng
        # Written only if the sampler found no goal state at all; canSample() is False by then,
        # and OMPL validity-checks what a goal region hands out.
        self._fallback = problem.start.copy()
        for column, value in problem.goal_columns.items():
            self._fallback[column] = value
        self._free = np.array([c for c in range(len(problem.start)) if c not in problem.goal_columns], dtype=np.int64)
        self.setThreshold(problem.tolerance)

    def distanceGoal(self, state) -> float:  # noqa: N802 (OMPL's name)
        return goal_distance(self.problem, state)

    def sampleGoal(self, state) -> None:  # noqa: N802
        values = self.goals.next()
        if values is None and self.goals.states:
            values = self._repeat()
        for i, v in enumerate((self._fallback if values is None else values).tolist()):
            state[i] = v

    def _repeat(self) -> np.ndarray:
        """One of the goal states found, drawn with the run's ``rng``, moved by :data:`REPEAT_OFFSET`."""
        states = self.goals.states
        values = states[int(self.rng.integers(len(states)))].copy()
        free = self._free
        if len(free):
            lower, upper = self.problem.lower[free], self.problem.upper[free]
            moved = values[free] + REPEAT_OFFSET * (upper - lower) * self.rng.uniform(-1.0, 1.0, len(free))
            values[free] = np.clip(moved, lower, upper)
        return values

    def maxSampleCount(self) -> int:  # noqa: N802
        # The sampler's capacity while it may find more, then what it found: BIT* stops asking
        # there, and never waits for a region that has nothing (couldSample() is canSample()).
        return len(self.goals.states) if self.goals.exhausted else self.goals.settings.capacity


def _setup(problem: Problem, goals: GoalSampler, rng: np.random.Generator):
    """SpaceInformation and ProblemDefinition for ``problem`` with the action-bound objective."""
    def region(si, problem, rng):
        return SharedGoalRegion(si, problem, goals, rng)

    si, pdef, validator, keep = ompl_setup(problem, planning_steps(problem), region, rng)
    objective = ObjectsMovedObjective(si, [list(c) for c in problem_factors(problem).values()])
    pdef.setOptimizationObjective(objective)
    # Python objects OMPL holds only by reference must outlive the run.
    return si, pdef, (keep, validator, objective)


def _solution(pdef, dimension: int) -> list[list[float]]:
    path = pdef.getSolutionPath()
    return [[path.getState(k)[i] for i in range(dimension)] for k in range(path.getStateCount())]


@dataclass(frozen=True)
class OmplRun:
    """One OMPL planner run: its result and what the planner built (for tests and diagnosis)."""

    result: PlanResult
    vertices: int  # vertices of the planner's graph at the end (PlannerData)
    goal_vertices: int  # of them, goal vertices (BIT*'s goal samples; RRT* marks none)
    goal_states: int  # goal states the shared sampler found in this run


BUDGET_SLICES = 50
"""Under a check budget, an OMPL planner is solved in this many slices of the budget (progress is
sampled between slices); a slice ends on the checks spent, so the slicing is the same on any machine."""


def run_ompl(name: str, make: Callable, problem: Problem, time_limit: float, seed: int,
             progress_interval: float = 0.1, until_first: bool = False, goal_seed: int | None = None,
             budget_checks: int | None = None, budget_cpu: float | None = None) -> OmplRun:
    """Run the OMPL planner ``make(si)`` for ``time_limit`` seconds, or ``budget_checks`` collision
    checks (motions charged by their length) or ``budget_cpu`` CPU seconds with the time limit as a
    backstop, or until its first solution that holds at fine resolution when ``until_first``; goal
    states from the shared sampler seeded with ``goal_seed`` (default: from ``seed``)."""
    problem = count_checks(problem, by_length=True)
    rng = np.random.default_rng(seed)
    goals = GoalSampler(problem, default_goal_seed(seed) if goal_seed is None else goal_seed)
    si, pdef, keep = _setup(problem, goals, rng)
    objective = keep[2]
    if until_first:
        objective.setCostThreshold(ob.Cost(math.inf))  # any solution satisfies: solve() returns at the first
    planner = make(si)
    planner.setProblemDefinition(pdef)
    planner.setup()
    recorder = AnytimeRecorder(name, problem, time_limit, progress_interval, budget_checks, budget_cpu)
    if not problem.model.is_valid(problem.start):
        return OmplRun(recorder.result(0, "Invalid start"), 0, 0, 0)
    dimension = len(problem.start)
    earlier = 0  # iterations of the trees cleared by restarts
    watch = _FirstSolutionWatch(recorder, planner)
    while not recorder.expired():
        planner.solve(_slice(recorder, progress_interval, watch))
        if pdef.hasExactSolution():
            # The moment the watch saw counts for a first solution only; later ones are read at a slice's end.
            found_at = None if recorder.has_solution else watch.found_at
            offer = recorder.offer_checked(_solution(pdef, dimension), found_at)
            if offer is Offer.BEST and until_first:
                recorder.sample(earlier + _iterations(planner, si), force=True)
                break
            if offer is Offer.CLIPPED:
                # The planner would keep the clipping path as its best until a strictly cheaper
                # one turns up, which never happens when it is already the cheapest (most often
                # one action per object), and every later path through the clipping edge clips
                # too: the run starts a fresh tree instead, with the time left and OMPL's RNG where
                # it is. Every planner restarts this way (LBT-RRT and both LA-RRT entries too;
                # docs/benchmark/README.md, "One restart rule").
                earlier += _iterations(planner, si)
                planner.clear()
                pdef.clearSolutionPaths()
                watch.found_at = None
        recorder.sample(earlier + _iterations(planner, si), force=True)
    result = recorder.result(earlier + _iterations(planner, si))
    data = ob.PlannerData(si)
    planner.getPlannerData(data)
    return OmplRun(result, data.numVertices(), data.numGoalVertices(), len(goals.states))


def _iterations(planner, si) -> int:
    """OMPL's iteration count where the planner reports one (RRT*, BIT*), else the vertices of its
    graph (RRT-Connect, PRM and others have no ``numIterations``)."""
    count = getattr(planner, "numIterations", None)
    if count is not None:
        return int(count())
    data = ob.PlannerData(si)
    planner.getPlannerData(data)
    return int(data.numVertices())


class _FirstSolutionWatch:
    """Notices, between two iterations of a ``solve`` slice, the moment an OMPL planner first holds a
    solution while the run has none, and ends the slice there, so that the path is checked and its
    time and checks are the ones measured then, not the end of the slice (0.1 s quick, 0.5 s paper,
    or 1/:data:`BUDGET_SLICES` of a budget). The planner's ``bestCost()`` (RRT*, BIT*) tells; a
    planner without one returns from ``solve`` at its first solution anyway (RRT-Connect, PRM...)."""

    def __init__(self, recorder: AnytimeRecorder, planner):
        self.recorder = recorder
        self.best_cost = getattr(planner, "bestCost", None)
        self.found_at: tuple[float, int] | None = None
        self.fired = False  # in this slice: OMPL may ask again after a True, and must hear True again

    def __call__(self) -> bool:
        """True when the slice should end now: a first solution has appeared in it."""
        if self.fired:
            return True
        if self.found_at is not None or self.recorder.has_solution or self.best_cost is None:
            return False
        if math.isfinite(self.best_cost().value()):
            self.found_at = self.recorder.moment()
            self.fired = True
        return self.fired


def _slice(recorder: AnytimeRecorder, progress_interval: float, watch: _FirstSolutionWatch):
    """The termination condition of one ``solve()`` slice: ``progress_interval`` seconds, or under
    a check budget a share of it in checks (the clock then only as the run's backstop); either ends
    early at the planner's first solution (``watch``)."""
    watch.fired = False
    if recorder.budget_cpu is not None:
        # A share of the CPU budget, in CPU seconds: the slicing follows the run's own work, not the load.
        end_cpu = recorder.cpu() + recorder.budget_cpu / BUDGET_SLICES
        return ob.PlannerTerminationCondition(lambda: watch() or recorder.cpu() >= end_cpu or recorder.expired())
    if recorder.budget_checks is None:
        end_time = recorder.elapsed() + max(min(recorder.time_limit - recorder.elapsed(), progress_interval), 1e-3)
        return ob.PlannerTerminationCondition(lambda: watch() or recorder.elapsed() >= end_time)
    end = recorder.checks() + max(1, math.ceil(recorder.budget_checks / BUDGET_SLICES))
    # OMPL asks this between iterations, in the planner's own thread: its answer depends on the
    # checks the planner made so far only (and on the backstop, which a budgeted run should not reach).
    return ob.PlannerTerminationCondition(lambda: watch() or recorder.checks() >= end or recorder.expired())


def ompl_plan_function(title: str, planner_class: Callable, configure: Callable | None = None) -> Callable:
    """A plan function for a :class:`~solver.planning.registry.Planner`'s ``plan`` that runs
    the ``ompl.geometric`` planner ``planner_class(si)`` on our collision model through
    :func:`run_ompl`: our state and motion validity checks (counted for check budgets), the shared
    goal sampler, the action-bound objective, anytime recording with fine-resolution checks and
    restarts. ``configure(planner)`` may set its parameters (``setRange``, ``setGoalBias``...)."""
    def make(si):
        planner = planner_class(si)
        if configure is not None:
            configure(planner)
        return planner

    def plan(problem: Problem, time_limit: float, seed: int, progress_interval: float = 0.1,
             until_first: bool = False, goal_seed: int | None = None, budget_checks: int | None = None,
             budget_cpu: float | None = None) -> PlanResult:
        return run_ompl(title, make, problem, time_limit, seed, progress_interval, until_first, goal_seed,
                        budget_checks, budget_cpu).result

    plan.__doc__ = f"OMPL's {title} through :func:`run_ompl`."
    plan.__qualname__ = plan.__name__ = f"plan_{planner_class.__name__}"
    return plan


def plan_rrt_star(problem: Problem, time_limit: float, seed: int, progress_interval: float = 0.1,
                  until_first: bool = False, goal_seed: int | None = None,
                  budget_checks: int | None = None, budget_cpu: float | None = None) -> PlanResult:
    """OMPL's RRT* (default range and goal bias) for ``time_limit`` seconds or a budget (:func:`run_ompl`)."""
    return run_ompl("RRT*", og.RRTstar, problem, time_limit, seed, progress_interval, until_first, goal_seed,
                    budget_checks, budget_cpu).result


def plan_bit_star(problem: Problem, time_limit: float, seed: int, progress_interval: float = 0.1,
                  until_first: bool = False, goal_seed: int | None = None,
                  budget_checks: int | None = None, budget_cpu: float | None = None) -> PlanResult:
    """OMPL's BIT* (default batch size) for ``time_limit`` seconds or a budget (:func:`run_ompl`)."""
    return run_ompl("BIT*", og.BITstar, problem, time_limit, seed, progress_interval, until_first, goal_seed,
                    budget_checks, budget_cpu).result
