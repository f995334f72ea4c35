"""BIT* (OMPL) over the robot's 10 joints: to a grasp, and from one grasp to the next.

Validity is a PyBullet query in the planning world (robot against the
puzzle as it stands now, and against itself). The planner stops at its
first solution, which is then shortened; BIT*'s informed search already
makes that first path direct in open space.

Deterministic: BIT* and the path simplifier draw from OMPL's seed
generator, which :func:`seed_reaching` reseeds for each puzzle (and each
solution tried), and a search that finds nothing ends after a budget of
validity checks, not of seconds, so that the answer does not depend on the
machine's load or on what ran before in the process.
"""

from __future__ import annotations

import math

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from phyrogen_core.seeding import stable_seed
from solver.planning.ompl_setup import seed_ompl

from .scene import COLLISION_MARGIN, World

BASE_MARGIN = 0.8
"""Metres the base may drive beyond the box spanned by start, goal and the puzzle's floor area."""
CHECK_STEP = 0.01
"""Radians (or metres) between collision-checked states along a motion (0.02 let a 1 cm finger pass
through the corner of a knob between two checks)."""
FINE_CHECK_STEP = 0.002
"""Radians (or metres) of any joint between collision-checked states of a short motion near a
handle (:func:`continuous_motion`): the tool moves at most a few millimetres between checks, less
than the planning margin, so no finger passes through a knob unseen."""
STRAIGHT_JOINT_STEP = 0.1
"""Radians any joint may turn while the tool moves one step (5 mm) of a straight approach: more is
a jump to another IK branch, not a straight motion."""
REACH_BUDGET = 30_000
"""Validity checks BIT* may spend on one motion before giving up (about 5 s at BIT*'s 6k checks/s)."""


def seed_reaching(*parts: object) -> None:
    """Seed the OMPL seed generator BIT* draws from (:func:`solver.planning.ompl_setup.seed_ompl`) from a
    stable hash of ``parts`` (say the puzzle's generator, name and seed)."""
    seed_ompl(stable_seed("ompl", "manipulation", *parts))


class ReachingError(RuntimeError):
    """BIT* found no collision-free robot motion within its budget."""


def continuous_motion(world: World, start: np.ndarray, end: np.ndarray,
                      max_joint_step: float | None = STRAIGHT_JOINT_STEP, margin: float = COLLISION_MARGIN) -> bool:
    """Whether the joint-space motion from ``start`` to ``end`` (the one the robot drives) keeps
    ``margin`` from the puzzle and does not touch itself, checked every :data:`FINE_CHECK_STEP`
    after ``start``, ``end`` always keeping the planning margin; and, unless ``max_joint_step`` is
    None, no joint turns more than that (a jump between IK branches is no short motion).
    Leaves the planning world's robot at ``end``."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    delta = end - start
    if max_joint_step is not None and float(np.max(np.abs(delta))) > max_joint_step:
        return False
    count = max(1, int(np.ceil(float(np.max(np.abs(delta))) / FINE_CHECK_STEP)))
    for k in range(1, count):
        world.set_robot(start + delta * (k / count))
        if world.in_collision(margin):
            return False
    world.set_robot(end)
    return not world.in_collision()


def plan_motion(world: World, start: np.ndarray, goal: np.ndarray, budget: int = REACH_BUDGET,
                area: tuple[float, float] = (0.6, 0.6)) -> np.ndarray:
    """A collision-free joint path from ``start`` to ``goal`` (rows of 10 values).

    ``budget``: validity checks BIT* may spend. ``area``: half the size (x, y) of
    the rectangle around the origin (the puzzle's floor area) the base may use,
    besides the start and goal positions, with :data:`BASE_MARGIN` around all.
    """
    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    dimension = len(start)
    lower, upper = world.lower.copy(), world.upper.copy()
    for axis in (0, 1):
        lower[axis] = max(lower[axis], min(start[axis], goal[axis], -area[axis]) - BASE_MARGIN)
        upper[axis] = min(upper[axis], max(start[axis], goal[axis], area[axis]) + BASE_MARGIN)
    lower[2] = max(lower[2], min(start[2], goal[2]) - math.pi)
    upper[2] = min(upper[2], max(start[2], goal[2]) + math.pi)
    space = ob.RealVectorStateSpace(dimension)
    bounds = ob.RealVectorBounds(dimension)
    for i in range(dimension):
        bounds.setLow(i, float(lower[i]))
        bounds.setHigh(i, float(upper[i]))
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)

    checks = 0

    def valid(state) -> bool:
        nonlocal checks
        checks += 1
        world.set_robot([state[i] for i in range(dimension)])
        return not world.in_collision()

    si.setStateValidityChecker(valid)
    si.setStateValidityCheckingResolution(CHECK_STEP / space.getMaximumExtent())
    si.setup()
    pdef = ob.ProblemDefinition(si)
    start_state, goal_state = si.allocState(), si.allocState()
    for i in range(dimension):
        start_state[i] = float(start[i])
        goal_state[i] = float(goal[i])
    pdef.addStartState(start_state)
    pdef.setGoalState(goal_state)
    objective = ob.PathLengthOptimizationObjective(si)
    objective.setCostThreshold(ob.Cost(math.inf))  # the first solution is enough
    pdef.setOptimizationObjective(objective)
    for name, values in (("start", start), ("goal", goal)):
        world.set_robot(values)
        if world.in_collision():
            raise ReachingError(f"the {name} configuration {np.round(values, 3).tolist()} is in collision")
    if si.checkMotion(start_state, goal_state):
        return np.array([start, goal], dtype=float)
    planner = og.BITstar(si)
    planner.setProblemDefinition(pdef)
    planner.setup()
    planner.solve(ob.PlannerTerminationCondition(lambda: checks >= budget))
    if not pdef.hasExactSolution():
        raise ReachingError(f"BIT* found no robot motion in {budget} validity checks")
    path = pdef.getSolutionPath()
    og.PathSimplifier(si).reduceVertices(path, 0, 0, 0.33)
    return np.array([[path.getState(k)[i] for i in range(dimension)] for k in range(path.getStateCount())])
