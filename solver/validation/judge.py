"""Is an object necessary? The FixJoint judge, robust to a shrink of every collision shape.

An object is *necessary* when the puzzle stays unsolvable with it fixed at
its start pose, even after every collision shape is shrunk by a margin (the
generator's ``interlock_margin``). Without the margin an object that leaves a
sliver of slack (a bar that blocks another by 0.3 degrees) counts as
necessary although a planner, or a real robot with a little play, gets past
it. The judge is LA-RRT with blocker pushes, our strongest planner, run until
its first solution or until a budget of collision queries is spent: a budget
in queries, never seconds, so the same puzzle gets the same verdict on every
machine.

The *measured margin* of an object is the largest shrink on a ladder
(:data:`MARGIN_LEVELS` times the required margin) at which the puzzle with
the object fixed is still unsolved: the ladder's resolution is a factor of
two, and the top rung means "at least this".
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from phyrogen_core.chain import KinematicChain
from phyrogen_core.puzzle import Goal
from solver.planning.la_rrt import LaRrtSettings, la_rrt_within
from solver.planning.problem import Path, UnreachableGoalError, chain_path, problem_for_chain

JUDGE_BUDGET = 4000
"""Collision queries (motions and batches of states) one judge run may spend in the Maker; the
audit (:mod:`solver.pipelines.audit`) re-checks every object with a far larger budget."""
JUDGE_SETTINGS = LaRrtSettings(goal_sample_attempts=10, resolution=0.005)
"""LA-RRT as benchmarked, with fewer goal candidates per iteration: with a lock fixed, no goal
state is ever valid, and 50 candidates an iteration spent most of the budget on them."""
MARGINAL_BUDGET_SCALE = 8
"""The budget of the run at the required margin, for objects already solved at every rung above:
in Continuous Space seed 500 a bar that blocks by less than the margin needed 600-10 000 queries
to be found superfluous, so 4000 missed it about half the time."""
MARGIN_LEVELS = (4, 2, 1)
"""Shrinks tried, as multiples of the required margin, top rung first: most objects block by far
more than the margin, and one unsolved run at the top rung settles them (shrinking never makes a
puzzle harder, so it blocks at every lower rung too)."""


@dataclass(frozen=True)
class Attempt:
    """One judge run: the puzzle with ``fixed`` objects held, shapes shrunk by ``shrink``."""

    fixed: tuple[str, ...]
    shrink: float
    solved: bool
    path: Path = ()  # chain joint order, fixed joints at their start value
    queries: int = 0


def attempt_fixed(chain: KinematicChain, goal: Goal, fixed: Sequence[str], shrink: float, budget: int,
                  rng: np.random.Generator) -> Attempt:
    """Try to solve ``chain`` with the objects ``fixed`` held at their start pose and every
    shape shrunk by ``shrink`` metres, spending at most about ``budget`` collision queries."""
    fixed = tuple(fixed)
    try:
        problem = problem_for_chain(chain, goal, fixed=fixed, shrink=shrink)
    except UnreachableGoalError:  # the target itself is fixed
        return Attempt(fixed, shrink, False)
    result, queries = la_rrt_within(problem, budget, rng, JUDGE_SETTINGS)
    path = chain_path(problem, result.path) if result.solved else ()
    return Attempt(fixed, shrink, result.solved, path, queries)


@dataclass(frozen=True)
class Necessity:
    """The judge's verdict on a group of objects fixed together."""

    necessary: bool
    margin: float  # the largest rung at which the puzzle stayed unsolved; 0 when not necessary
    queries: int
    witness: Attempt | None = None  # the solved attempt at the required margin, when not necessary


def judge(chain: KinematicChain, goal: Goal, fixed: Sequence[str], margin: float, budget: int,
          rng: np.random.Generator) -> Necessity:
    """Whether the objects ``fixed`` are necessary at ``margin``, and their measured margin.

    Rungs are tried from the top (:data:`MARGIN_LEVELS`); the first unsolved one is the
    measured margin. Solved at every rung down to ``margin`` itself: not necessary.
    """
    queries = 0
    attempt = None
    levels = MARGIN_LEVELS if margin > 0 else (1,)
    for level in levels:
        # Reaching the required rung means the puzzle was solved at every rung above it: the
        # objects block by a sliver at most, and a verdict there needs a longer search.
        scale = MARGINAL_BUDGET_SCALE if level == levels[-1] and len(levels) > 1 else 1
        attempt = attempt_fixed(chain, goal, fixed, level * margin, budget * scale, rng)
        queries += attempt.queries
        if not attempt.solved:
            return Necessity(True, level * margin, queries)
    return Necessity(False, 0.0, queries, attempt)


def warm_up() -> None:
    """Load the judge's compiled loop (from numba's cache, or compile it) on a two-box puzzle: a
    server process does it once before it forks workers, so that no worker pays for it."""
    from phyrogen_core.chain import Geometry
    from phyrogen_core.geometry import Box, Pose
    from phyrogen_core.objects import Motion, PuzzleObject, build_chain

    geometry = (Geometry(Box((1.0, 1.0, 1.0))),)
    chain = build_chain([PuzzleObject(f"obj_0{i}", Motion.PRISMATIC, Pose.planar(1.5 * i, 0.0, 0.5), geometry,
                                      geometry, limits=((0.0, 1.0),)) for i in range(2)])
    goal = Goal("obj_00", {chain.joint_order[0]: 1.0})
    attempt_fixed(chain, goal, ["obj_01"], 0.0, 50, np.random.default_rng(0))
