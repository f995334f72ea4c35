"""ValidatePuzzle: can the target reach its goal? RRT-Connect (OMPL) on our collision model.

This is OMPL's side of validation: the OMPL set-up of a
:class:`~solver.problem.Problem`, RRT-Connect with a budget, and the Maker's
validator. The problem itself, densifying and checking certificates, and
the dependency graph need no OMPL and live in :mod:`solver.problem`.

Budgets are counted in motion checks, never seconds, so the answer (and
therefore every generated puzzle) is the same on any machine. Each puzzle
seeds OMPL's seed generator at its start (:func:`seed_ompl`), and the goal
sampler draws from its own seeded numpy Generator.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from phyrogen_core.maker import SolveResult
from phyrogen_core.objects import PuzzleObject, build_chain
from phyrogen_core.puzzle import Goal

from .collision import CollisionModel
from .judge import JUDGE_BUDGET, judge
from .problem import (
    DEFAULT_RESOLUTION,
    FINE_RESOLUTION,
    Problem,
    chain_path,
    goal_distance,
    in_goal,
    path_is_valid,
    problem_for_objects,
    verify_certificate,
)

DEFAULT_BUDGET = 4000
"""Collision queries (motion checks plus single-state checks) RRT-Connect may spend
before a puzzle counts as unsolved."""


class _MotionValidator(ob.MotionValidator):
    """Checks a whole segment in one compiled call and counts the checks."""

    def __init__(self, si, model: CollisionModel, steps: np.ndarray):
        super().__init__(si)
        self.model = model
        self.steps = steps
        self.dimension = len(steps)
        self.calls = 0
        self._a = np.empty(self.dimension)
        self._b = np.empty(self.dimension)

    def checkMotion(self, s1, s2) -> bool:  # noqa: N802 (OMPL's name)
        self.calls += 1
        for i in range(self.dimension):
            self._a[i] = s1[i]
            self._b[i] = s2[i]
        return self.model.check_motion(self._a, self._b, self.steps)


class _GoalRegion(ob.GoalSampleableRegion):
    """Target joints at their goal values; every other joint anywhere within limits."""

    def __init__(self, si, problem: Problem, rng: np.random.Generator):
        super().__init__(si)
        self.problem = problem
        self.columns = problem.goal_columns
        self.lower, self.upper = problem.lower, problem.upper
        self.rng = rng
        self._block = np.empty((0, len(self.lower)))
        self._next = 0
        self.setThreshold(problem.tolerance)

    def distanceGoal(self, state) -> float:  # noqa: N802
        return goal_distance(self.problem, state)

    def sampleGoal(self, state) -> None:  # noqa: N802
        # Uniform draws come in blocks: one numpy call per state would dominate the cost.
        if self._next == len(self._block):
            self._block = self.lower + (self.upper - self.lower) * self.rng.random((256, len(self.lower)))
            self._block[:, list(self.columns)] = list(self.columns.values())
            self._next = 0
        values = self._block[self._next].tolist()
        self._next += 1
        for i, v in enumerate(values):
            state[i] = v

    def maxSampleCount(self) -> int:  # noqa: N802
        return 1 << 30


def ompl_setup(problem: Problem, steps: np.ndarray, goal_type: type, rng: np.random.Generator):
    """OMPL's SpaceInformation and ProblemDefinition for ``problem`` on our collision model.

    Motions are checked in one compiled call each (``steps`` per joint); the
    returned motion validator counts motion and single-state checks in
    ``calls``. ``goal_type`` is :class:`_GoalRegion` or a subclass. The last
    item holds Python objects OMPL references but does not own: keep it alive.
    """
    ou.setLogLevel(ou.LogLevel.LOG_NONE)  # invalid goal samples are expected, not errors
    model = problem.model
    dimension = len(problem.start)
    space = ob.RealVectorStateSpace(dimension)
    bounds = ob.RealVectorBounds(dimension)
    for i in range(dimension):
        bounds.setLow(i, float(problem.lower[i]))
        bounds.setHigh(i, float(problem.upper[i]))
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    validator = _MotionValidator(si, model, steps)
    buffer = np.empty((1, dimension))
    row = buffer[0]

    def state_valid(s) -> bool:
        # Counted too: with an invalid goal, RRT-Connect only samples goal states.
        validator.calls += 1
        for i in range(dimension):
            row[i] = s[i]
        return bool(model.check_prepared(buffer)[0])

    si.setStateValidityChecker(state_valid)
    si.setMotionValidator(validator)
    si.setup()
    pdef = ob.ProblemDefinition(si)
    start = si.allocState()
    for i in range(dimension):
        start[i] = float(problem.start[i])
    pdef.addStartState(start)
    goal = goal_type(si, problem, rng)
    pdef.setGoal(goal)
    return si, pdef, validator, (space, state_valid, start, goal)


def rrt_connect(problem: Problem, budget: int, rng: np.random.Generator,
                resolution: float = DEFAULT_RESOLUTION) -> SolveResult:
    """RRT-Connect until a path is found or ``budget`` collision queries are spent."""
    if not problem.model.is_valid(problem.start):
        return SolveResult(False)
    dimension = len(problem.start)
    si, pdef, validator, _keep = ompl_setup(problem, problem.model.motion_steps(resolution), _GoalRegion, rng)
    planner = og.RRTConnect(si)
    planner.setProblemDefinition(pdef)
    planner.setup()
    status = planner.solve(ob.PlannerTerminationCondition(lambda: validator.calls >= budget))
    if not pdef.hasExactSolution() or str(status) != "Exact solution":
        return SolveResult(False, (), validator.calls)
    path = pdef.getSolutionPath()
    states = tuple(tuple(float(path.getState(k)[i]) for i in range(dimension)) for k in range(path.getStateCount()))
    return SolveResult(True, states, validator.calls)


def seed_ompl(seed: int) -> None:
    """Seed OMPL's seed generator, from which every OMPL RNG made afterwards (each planner and
    state sampler makes its own) takes its seed: a run seeded first draws the same numbers in any
    process, whatever ran there before (OMPL logs a needless error about it, silenced here)."""
    level = ou.getLogLevel()
    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    ou.RNG.setSeed(int(seed))
    ou.setLogLevel(level)


EXTENSION_GRID = 25
"""Evenly spaced values of a new joint tried when extending a previous certificate."""


class OmplValidator:
    """The Maker's Validator: extend the last certificate, else RRT-Connect with a budget.

    The Maker grows a puzzle one object at a time, so the puzzle before the
    new object was just shown solvable. A witness for the new puzzle is often
    "move the new object out of the way, then replay the old certificate";
    that is tried first (any collision-free path to the goal proves
    solvability, checked at fine resolution). RRT-Connect, whose cost grows
    steeply with the number of objects in narrow-passage families, is the
    fallback. ``rng`` drives goal sampling; OMPL's own RNG must have been
    seeded by the caller (:func:`seed_ompl`).
    """

    def __init__(self, rng: np.random.Generator, budget: int = DEFAULT_BUDGET,
                 resolution: float = DEFAULT_RESOLUTION):
        self.rng = rng
        self.budget = budget
        self.resolution = resolution
        self.checks = 0
        self._solved: dict[tuple[PuzzleObject, ...], tuple[tuple[float, ...], ...]] = {}

    def solve(self, objects: Sequence[PuzzleObject], goal: Goal, *, budget_scale: float = 1.0) -> SolveResult:
        objects = tuple(objects)
        problem = problem_for_objects(objects, goal)
        if problem is None:
            return SolveResult(False)
        budget = int(self.budget * budget_scale)
        path = self._extend_previous(objects, goal)
        if path is None:
            previous = self._previous_with_same_joints(objects)
            if previous is not None:
                path = self._replan_tail(problem, previous, self.resolution, budget)
        if path is None:
            result = rrt_connect(problem, budget, self.rng, self.resolution)
            self.checks += result.checks
            if not result.solved:
                return result
            path = chain_path(problem, result.path)
        self._solved[objects] = path
        return SolveResult(True, path, 0)

    def _solved_prefix(self, objects: tuple[PuzzleObject, ...]) -> int | None:
        """The length of the longest proper prefix of ``objects`` solved before, or None."""
        return next((k for k in range(len(objects) - 1, 0, -1) if objects[:k] in self._solved), None)

    def _previous_with_same_joints(self, objects: tuple[PuzzleObject, ...]):
        """The certificate of the longest solved prefix of ``objects`` when every object added
        since is fixed (walls, corridors): its states are states of the new puzzle too."""
        prefix = self._solved_prefix(objects)
        if prefix is None or any(o.is_movable for o in objects[prefix:]):
            return None
        return self._solved[objects[:prefix]]

    def _replan_tail(self, problem: Problem, path, resolution: float, budget: int):
        """Factored validation: keep the longest prefix of ``path`` (chain joint order) that is
        collision-free at ``resolution`` and plan only the rest, from where it stops.

        When the new objects are walls (a corridor of Move N Times) the old certificate still
        holds up to the new walls, so only the new level is searched: the cost of a puzzle
        grows with its levels instead of 4x per level. Returns None when no path is found
        within ``budget`` queries (the caller then plans from the start)."""
        model = problem.model
        columns = [model.chain.joint_order.index(j) for j in model.joint_order]
        states = np.asarray(path, dtype=np.float64)[:, columns]
        steps = model.motion_steps(resolution)
        if not model.is_valid(states[0]) or np.any(np.abs(states[0] - problem.start) > 1e-12):
            return None
        kept = 1
        while kept < len(states) and model.check_motion(states[kept - 1], states[kept], steps):
            kept += 1
        self.checks += kept
        if kept == len(states) and in_goal(problem, states[-1]):
            return chain_path(problem, states)
        result = rrt_connect(replace(problem, start=states[kept - 1]), budget, self.rng, resolution)
        self.checks += result.checks
        if not result.solved:
            return None
        return chain_path(problem, np.concatenate([states[:kept - 1], np.array(result.path)]))

    def necessity(self, objects: Sequence[PuzzleObject], goal: Goal, fixed: Sequence[str], margin: float, *,
                  budget_scale: float = 1.0) -> float | None:
        """The Maker's FixJoint: :func:`solver.judge.judge` with ``budget_scale`` times
        :data:`~solver.judge.JUDGE_BUDGET`; None when the objects ``fixed`` are superfluous, else
        their measured margin. (The judge's budget does not grow with :attr:`budget`: LA-RRT's
        pushes need no larger search where RRT-Connect does, as in Move N Times.)"""
        verdict = judge(build_chain(tuple(objects)), goal, fixed, margin, int(JUDGE_BUDGET * budget_scale), self.rng)
        self.checks += verdict.queries
        return verdict.margin if verdict.necessary else None

    def _extend_previous(self, objects: tuple[PuzzleObject, ...], goal: Goal):
        """A certificate for ``objects`` built from one for a prefix of them, or None."""
        prefix = self._solved_prefix(objects)
        if prefix is None:
            return None
        old_chain = build_chain(objects[:prefix])
        chain = build_chain(objects)
        new_joints = [j for j in chain.joint_order if j not in old_chain.joint_order]
        if len(new_joints) > 1:
            return None  # a grid over several new joints is not worth it; RRT-Connect decides
        model = CollisionModel(chain)
        # Candidates are screened at the validator's resolution (most parkings fail, and fail
        # fast there); the one kept must hold at fine resolution, as certificates do.
        coarse, fine = model.motion_steps(self.resolution), model.motion_steps(FINE_RESOLUTION)
        old_path = [dict(zip(old_chain.joint_order, state, strict=True)) for state in self._solved[objects[:prefix]]]
        for value in _parking_values(chain, new_joints):
            rows = [{**old_path[0], **{j: 0.0 for j in new_joints}}]
            rows += [{**state, **{j: value for j in new_joints}} for state in old_path]
            path = np.array([[row[j] for j in chain.joint_order] for row in rows])
            if not goal.is_reached(chain.state_dict(path[-1])):
                return None
            self.checks += len(path)
            if all(model.check_motion(a, b, coarse) for a, b in zip(path[:-1], path[1:], strict=True)) and \
                    path_is_valid(model, path, fine):
                return tuple(tuple(float(v) for v in row) for row in path)
        return None

    def certify(self, objects: Sequence[PuzzleObject], goal: Goal, path, *, budget_scale: float = 1.0):
        """A certificate that holds at :data:`FINE_RESOLUTION`: ``path`` itself when it does,
        else a path planned again at that resolution (a path planned coarsely can clip a
        corner between two checked states). Returns None when none is found."""
        chain = build_chain(objects)
        if not verify_certificate(chain, path, goal):
            return tuple(path)
        # Most coarse paths clip a corner late or not at all: re-plan from the last fine-valid state first.
        problem = problem_for_objects(objects, goal)
        if problem is not None:
            repaired = self._replan_tail(problem, path, FINE_RESOLUTION, int(self.budget * budget_scale))
            if repaired is not None and not verify_certificate(chain, repaired, goal):
                return repaired
        fine = OmplValidator(self.rng, self.budget, FINE_RESOLUTION)
        result = fine.solve(objects, goal, budget_scale=budget_scale)
        self.checks += fine.checks
        if result.solved and not verify_certificate(chain, result.path, goal):
            return result.path
        return None


def _parking_values(chain, new_joints: list[str]) -> list[float]:
    """Where to park a new joint before replaying: its limits, 45 degree steps, then a grid."""
    if not new_joints:
        return [0.0]
    joint = chain.joint(new_joints[0])
    values = [joint.lower, joint.upper]
    if joint.type.value == "revolute":
        values += [k * np.pi / 4 for k in range(-8, 9) if joint.lower <= k * np.pi / 4 <= joint.upper]
    values += list(np.linspace(joint.lower, joint.upper, EXTENSION_GRID))
    unique: list[float] = []
    for v in values:
        if all(abs(v - u) > 1e-9 for u in unique):
            unique.append(float(v))
    return unique
