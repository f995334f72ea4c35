"""ValidatePuzzle: can the target reach its goal? RRT-Connect (OMPL) on our collision model.

Budgets are counted in motion checks, never seconds, so the answer (and
therefore every generated puzzle) is the same on any machine. OMPL's global
RNG can be seeded only once per process; :mod:`solver.generation` therefore
runs each puzzle in a fresh worker process and seeds it there, and the goal
sampler draws from its own seeded numpy Generator.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from phyrogen_core.maker import SolveResult
from phyrogen_core.objects import PuzzleObject, build_chain
from phyrogen_core.puzzle import Goal

from .collision import CollisionModel

DEFAULT_BUDGET = 4000
"""Collision queries (motion checks plus single-state checks) RRT-Connect may spend
before a puzzle counts as unsolved."""
DEFAULT_RESOLUTION = 0.02
"""Metres any collision point may move between two checked states while planning."""
FINE_RESOLUTION = 0.002
"""Metres between checked states when a certificate is re-checked."""


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

    def __init__(self, si, goal_columns: dict[int, float], lower, upper, tolerance, rng):
        super().__init__(si)
        self.columns = goal_columns
        self.lower, self.upper = lower, upper
        self.rng = rng
        self._block = np.empty((0, len(lower)))
        self._next = 0
        self.setThreshold(tolerance)

    def distanceGoal(self, state) -> float:  # noqa: N802
        return max(abs(state[i] - v) for i, v in self.columns.items())

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


@dataclass(frozen=True)
class Problem:
    """A planning problem over the free joints of a chain (locked joints held at start)."""

    model: CollisionModel
    start: np.ndarray
    goal_columns: dict[int, float]
    lower: np.ndarray
    upper: np.ndarray
    tolerance: float


def make_problem(objects: Sequence[PuzzleObject], goal: Goal) -> Problem | None:
    """The problem for ``objects``; None when the target cannot move to its goal at all
    (its goal joints are fixed away from the goal)."""
    chain = build_chain(objects)
    # Joints of fixed-range (lower == upper) count as locked: OMPL rejects empty bounds.
    locked = {j.name: j.lower for j in chain.active_joints if j.upper - j.lower < 1e-12}
    for name, value in goal.values.items():
        if name not in chain.joint_order:
            return None  # the target is fixed (FixJoint of the target)
        if name in locked and abs(locked[name] - value) > goal.tolerance:
            return None
    model = CollisionModel(chain, {n: max(min(0.0, chain.joint(n).upper), chain.joint(n).lower) for n in locked})
    order = model.joint_order
    lower = np.array([chain.joint(n).lower for n in order])
    upper = np.array([chain.joint(n).upper for n in order])
    start = np.clip(np.zeros(len(order)), lower, upper)
    columns = {order.index(n): v for n, v in goal.values.items() if n in order}
    return Problem(model, start, columns, lower, upper, goal.tolerance)


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
    goal = goal_type(si, problem.goal_columns, problem.lower, problem.upper, problem.tolerance, rng)
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


def full_path(objects: Sequence[PuzzleObject], problem: Problem, path) -> tuple[tuple[float, ...], ...]:
    """Expand a path over the problem's free joints to all active joints (locked ones at their value)."""
    chain = build_chain(objects)
    order = problem.model.joint_order
    locked = problem.model.locked
    rows = []
    for state in path:
        values = dict(zip(order, state, strict=True))
        rows.append(tuple(float(values.get(n, locked.get(n, 0.0))) for n in chain.joint_order))
    return tuple(rows)


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
    seeded by the caller (see :func:`solver.generation.seed_ompl`).
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
        problem = make_problem(objects, goal)
        if problem is None:
            return SolveResult(False)
        path = self._extend_previous(objects, goal)
        if path is None:
            result = rrt_connect(problem, int(self.budget * budget_scale), self.rng, self.resolution)
            self.checks += result.checks
            if not result.solved:
                return result
            path = full_path(objects, problem, result.path)
        self._solved[objects] = path
        return SolveResult(True, path, 0)

    def _extend_previous(self, objects: tuple[PuzzleObject, ...], goal: Goal):
        """A certificate for ``objects`` built from one for a prefix of them, or None."""
        prefix = next((k for k in range(len(objects) - 1, 0, -1) if objects[:k] in self._solved), None)
        if prefix is None:
            return None
        old_chain = build_chain(objects[:prefix])
        chain = build_chain(objects)
        new_joints = [j for j in chain.joint_order if j not in old_chain.joint_order]
        if len(new_joints) > 1:
            return None  # a grid over several new joints is not worth it; RRT-Connect decides
        model = CollisionModel(chain)
        steps = model.motion_steps(FINE_RESOLUTION)
        old_path = [dict(zip(old_chain.joint_order, state, strict=True)) for state in self._solved[objects[:prefix]]]
        for value in _parking_values(chain, new_joints):
            rows = [{**old_path[0], **{j: 0.0 for j in new_joints}}]
            rows += [{**state, **{j: value for j in new_joints}} for state in old_path]
            path = np.array([[row[j] for j in chain.joint_order] for row in rows])
            if not goal.is_reached(chain.state_dict(path[-1])):
                return None
            self.checks += len(path)
            if all(model.check_motion(a, b, steps) for a, b in zip(path[:-1], path[1:], strict=True)):
                return tuple(tuple(float(v) for v in row) for row in path)
        return None

    def certify(self, objects: Sequence[PuzzleObject], goal: Goal, path, *, budget_scale: float = 1.0):
        """A certificate that holds at :data:`FINE_RESOLUTION`: ``path`` itself when it does,
        else a path planned again at that resolution (a path planned coarsely can clip a
        corner between two checked states). Returns None when none is found."""
        if not verify_certificate(build_chain(objects), path, goal):
            return tuple(path)
        fine = OmplValidator(self.rng, self.budget, FINE_RESOLUTION)
        result = fine.solve(objects, goal, budget_scale=budget_scale)
        self.checks += fine.checks
        if result.solved and not verify_certificate(build_chain(objects), result.path, goal):
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


def densify(path, steps: np.ndarray) -> np.ndarray:
    """All states along a piecewise-linear path with at most ``steps[j]`` per joint between rows."""
    path = np.asarray(path, dtype=float)
    rows = [path[:1]]
    for a, b in zip(path[:-1], path[1:], strict=True):
        count = max(1, int(np.ceil(np.max(np.abs(b - a) / steps))))
        t = np.arange(1, count + 1)[:, None] / count
        rows.append(a + (b - a) * t)
    return np.concatenate(rows)


def verify_certificate(chain, path, goal: Goal, resolution: float = FINE_RESOLUTION) -> list[str]:
    """Problems with a certificate (empty when it is valid): starts at the start state,
    stays collision-free at ``resolution``, within limits, and ends in the goal."""
    problems: list[str] = []
    if len(path) < 1:
        return ["certificate is empty"]
    model = CollisionModel(chain)
    states = np.asarray(path, dtype=float)
    if states.shape[1] != len(chain.joint_order):
        return [f"certificate states have {states.shape[1]} values, chain has {len(chain.joint_order)} joints"]
    if np.max(np.abs(states[0])) > 1e-9:
        problems.append("certificate does not begin at the start state")
    lower, upper = chain.lower_limits, chain.upper_limits
    if np.any(states < lower - 1e-9) or np.any(states > upper + 1e-9):
        problems.append("certificate leaves the joint limits")
    dense = densify(states, model.motion_steps(resolution))
    bad = np.flatnonzero(~model.check(dense))
    if bad.size:
        problems.append(f"certificate collides at {bad.size} of {len(dense)} checked states")
    if not goal.is_reached(chain.state_dict(states[-1])):
        problems.append("certificate does not end in the goal")
    return problems


def dependency_graph(objects: Sequence[PuzzleObject], certificate, resolution: float = DEFAULT_RESOLUTION
                     ) -> tuple[tuple[str, str], ...]:
    """(blocker, blocked) pairs read off a certificate.

    Object B blocks object A when A's motion along the certificate would run
    into B had B stayed at its start pose: B had to get out of A's way.
    """
    chain = build_chain(objects)
    model = CollisionModel(chain)
    states = densify(certificate, model.motion_steps(resolution))
    edges: set[tuple[str, str]] = set()
    for blocker, columns in chain.factors.items():
        frozen = states.copy()
        frozen[:, list(columns)] = 0.0
        edges |= {(blocker, a if b == blocker else b) for a, b in model.colliding_objects(frozen) if blocker in (a, b)}
    return tuple(sorted(edges))
