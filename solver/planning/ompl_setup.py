"""OMPL set-up of a :class:`~solver.planning.problem.Problem`: our collision model as OMPL's state
and motion validity checkers, a goal region, RRT-Connect with a budget in collision queries, and the
seeding of OMPL's own random numbers (:func:`seed_ompl`).

Budgets are counted in collision queries, never seconds, so an answer is the same on any machine.
"""

from __future__ import annotations

import ctypes

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from phyrogen_core.maker import SolveResult
from solver.collision.kernels import motion_collides_packed, state_valid_packed
from solver.collision.model import CollisionModel
from solver.planning.problem import DEFAULT_RESOLUTION, Problem, goal_distance

_CAPSULE_NEW = ctypes.pythonapi.PyCapsule_New
_CAPSULE_NEW.restype = ctypes.py_object
_CAPSULE_NEW.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_void_p]
_HANDLE = b"nb_handle"  # the capsule name OMPL's bindings read a raw pointer from


class _RawStates:
    """One call to OMPL per state read instead of one indexing call per joint: the space's ``serialize``
    (a ``memcpy`` of a real vector state's doubles) into a numpy row, the same bits. ``None`` from
    :meth:`of` where the bindings take no raw pointer, or the copy does not give back what indexing
    reads (then the callers index joint by joint, as before)."""

    def __init__(self, space, rows: np.ndarray):
        self.rows = rows  # kept alive with the capsules that point into it
        self.capsules = [_CAPSULE_NEW(row.ctypes.data, _HANDLE, None) for row in rows]
        self.read = space.serialize  # read(capsule, state): state -> row

    @classmethod
    def of(cls, space, dimension: int, count: int, probe) -> _RawStates | None:
        """The rows and their capsules, checked on ``probe`` (a state of ``space`` it overwrites: OMPL's
        bindings never free an allocated state, so the caller lends one it needs anyway)."""
        try:
            if space.getSerializationLength() != 8 * dimension:
                return None
            raw = cls(space, np.zeros((count, dimension)))
            values = [0.5 + i / 3.0 for i in range(dimension)]
            for i, v in enumerate(values):
                probe[i] = v
            for capsule, row in zip(raw.capsules, raw.rows, strict=True):
                raw.read(capsule, probe)
                if row.tolist() != values:
                    return None
        except (TypeError, ValueError, AttributeError):
            return None
        return raw


def _compiled(dispatcher, arguments: tuple):
    """The machine code numba's ``dispatcher`` runs for exactly these arguments' types, called without its
    type dispatch (a planner calls it with the same arrays every time); the dispatcher itself where that
    code is not compiled yet in this process."""
    try:
        found = dispatcher.overloads.get(tuple(map(dispatcher.typeof_pyval, arguments)))
    except (AttributeError, TypeError, ValueError):
        found = None
    return dispatcher if found is None else found.entry_point


class _MotionValidator(ob.MotionValidator):
    """Checks a whole segment in one compiled call and counts the checks."""

    def __init__(self, si, model: CollisionModel, steps: np.ndarray, raw: _RawStates | None = None):
        super().__init__(si)
        self.model = model
        self.steps = steps
        self.dimension = len(steps)
        self.calls = 0
        self._a = np.empty(self.dimension)
        self._b = np.empty(self.dimension)
        # Our own model: its packed arrays straight to the compiled motion check (six arguments, not sixteen).
        self._packed = model.packed if type(model) is CollisionModel else None
        self._raw = raw
        if raw is not None and self._packed is not None:
            # The states copied into two rows (one call each), the check's arguments always these arrays.
            self._read, self._cap_a, self._cap_b = raw.read, raw.capsules[0], raw.capsules[1]
            self._arguments = (raw.rows[0], raw.rows[1], steps, *self._packed)
            self._check = _compiled(motion_collides_packed, self._arguments)
        else:
            self._raw = None

    def checkMotion(self, s1, s2) -> bool:  # noqa: N802 (OMPL's name)
        self.calls += 1
        if self._raw is not None:
            self._read(self._cap_a, s1)
            self._read(self._cap_b, s2)
            return not self._check(*self._arguments)
        a, b = self._a, self._b
        for i in range(self.dimension):
            a[i] = s1[i]
            b[i] = s2[i]
        if self._packed is not None:
            return not motion_collides_packed(a, b, self.steps, *self._packed)
        return self.model.check_motion(a, b, self.steps)


class _GoalRegion(ob.GoalSampleableRegion):
    """Target joints at their goal values; every other joint anywhere within limits."""

    def __init__(self, si, problem: Problem, rng: np.random.Generator):
        super().__init__(si)
        self.problem = problem
        self.columns = problem.goal_columns
        self.lower, self.upper = problem.lower, problem.upper
        self.rng = rng
        self._block: list[list[float]] = []
        self._next = 0
        self.setThreshold(problem.tolerance)

    def distanceGoal(self, state) -> float:  # noqa: N802
        return goal_distance(self.problem, state)

    def sampleGoal(self, state) -> None:  # noqa: N802
        # Uniform draws come in blocks: one numpy call per state would dominate the cost.
        if self._next == len(self._block):
            block = self.lower + (self.upper - self.lower) * self.rng.random((256, len(self.lower)))
            block[:, list(self.columns)] = list(self.columns.values())
            self._block = block.tolist()
            self._next = 0
        values = self._block[self._next]
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
    start = si.allocState()  # first the raw reads' probe, then the start state
    raw = _RawStates.of(space, dimension, 3, start)
    validator = _MotionValidator(si, model, steps, raw)
    buffer = np.empty((1, dimension)) if raw is None else raw.rows[2:]
    row = buffer[0]

    ints, floats, _ = model.packed if type(model) is CollisionModel else (None, None, None)
    read, capsule = (None, None) if raw is None else (raw.read, raw.capsules[2])
    valid = state_valid_packed if ints is None else _compiled(state_valid_packed, (row, ints, floats))

    def state_valid(s) -> bool:
        # Counted too: with an invalid goal, RRT-Connect only samples goal states.
        validator.calls += 1
        if read is not None:
            read(capsule, s)
        else:
            for i in range(dimension):
                row[i] = s[i]
        if ints is not None:  # our own model: the packed entry point, the same verdicts
            return valid(row, ints, floats)
        return bool(model.check_prepared(buffer)[0])

    si.setStateValidityChecker(state_valid)
    si.setMotionValidator(validator)
    si.setup()
    pdef = ob.ProblemDefinition(si)
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
