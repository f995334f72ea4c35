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

A verdict "unsolved" is only as strong as the planner that failed, so there
are two judges, and a rung counts as unsolved only when **both** fail:

1. the first judge, LA-RRT with pushes (compiled loop, :func:`attempt_fixed`),
   whose goal roots are uniform goal candidates and start-tree nodes with the
   target moved to its goal, checked in batches paid from its query budget;
2. the second judge, LA-RRT as the paper defines it (isolated steps, no
   pushes; :data:`SECOND_JUDGE_SETTINGS`, :func:`attempt_second`), a
   different search with goal states of its own: the shared goal sampler
   (:mod:`solver.planning.goal_sampling`, min-conflicts repair) on its own
   seed, bound to the run so that sampling is paid from the run's check
   budget and ends with it. Its numbers come from numpy Generators only:
   an OMPL planner here would draw seeds from OMPL's global seed generator
   and shift every later OMPL run of the Maker.

The second judge also says whether the goal region itself had valid states
(:class:`~solver.planning.goal_sampling.GoalAccount`). A necessary verdict
whose second judge found no goal state at all is recorded as
:data:`NO_GOAL_STATE` ("no valid goal state found with the object fixed, N
states checked"): the object is necessary in the strong sense that it keeps
the target's goal itself out of reach of every valid state (as far as the
sampler's search shows; it is evidence, not a proof). One with goal states
is :data:`NO_PATH` ("goal states exist, no path within the budget"). Both
keep the object; the record says which.

The *measured margin* of an object is the largest shrink on a ladder
(:data:`MARGIN_LEVELS` times the required margin) at which the puzzle with
the object fixed is still unsolved: the ladder's resolution is a factor of
two, and the top rung means "at least this".
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from phyrogen_core.chain import KinematicChain
from phyrogen_core.maker import BY_GEOMETRY, BY_GOAL_SAMPLER, BY_SEARCH
from phyrogen_core.puzzle import Goal
from phyrogen_core.seeding import stable_seed
from solver.planning.anytime import AnytimeRecorder, count_checks
from solver.planning.goal_sampling import GoalAccount, GoalSampler, GoalSamplerSettings
from solver.planning.la_rrt import PAPER_SETTINGS, LaRrt, LaRrtSettings, la_rrt_within
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
SECOND_JUDGE_BUDGET = 2000
"""Collision checks one second-judge run may spend in the Maker, goal sampling included (each state
checked counts, a batch of 64 goal candidates 64), so it is a smaller search than the first judge's
4000 queries. With 4000 the Maker took 2.0-2.1x the CPU time of the first judge alone on the paper's
24 puzzles (its loop was Python then, the first judge's compiled); with 2000 and 4 goal states, 1.6x
(3.5 -> 5.5 CPU s). The audit gives it 50x this (:func:`solver.pipelines.audit.second_budget`)."""
SECOND_JUDGE_GOALS = GoalSamplerSettings(capacity=4)
"""The second judge's goal sampler: at most 4 goal states (the benchmark's 16 cost a first-solution
search checks it needs elsewhere: with a superfluous slider planted in a Simple Slider, 2000 checks
solved 9 of 10 seeds with 16 goal states, 10 of 10 with 4)."""
SECOND_JUDGE_SETTINGS = PAPER_SETTINGS
"""The second judge: LA-RRT as the paper defines it (isolated steps, plain L1 metric, no pushes,
goal roots by the half-tree rule from its own goal sampler)."""
FIRST_JUDGE = "la_rrt_push"
SECOND_JUDGE = "la_rrt_paper"
GEOMETRY = "geometry"
"""The judge of an attempt settled by :class:`~solver.validation.blocking.BlockingProver`, not by a search."""
NO_GOAL_STATE = "no valid goal state"
"""A necessary verdict whose second judge found no valid goal state with the objects fixed."""
NO_PATH = "no path"
"""A necessary verdict whose second judge found goal states but neither judge a path to one."""
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
    queries: int = 0  # the first judge's queries (motions and batches); the second judge's checks
    judge: str = FIRST_JUDGE
    goals: GoalAccount | None = None  # the second judge's goal sampling (the first judge's is in its loop)


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


def attempt_second(chain: KinematicChain, goal: Goal, fixed: Sequence[str], shrink: float, budget: int,
                   seed: int, *, compiled: bool = True) -> Attempt:
    """The second judge's try at ``chain`` with ``fixed`` held and shapes shrunk by ``shrink``: until
    its first solution or until ``budget`` collision checks are spent, goal sampling included
    (the sampler's stream is seeded apart from the planner's, both from ``seed``). The loop and the
    goal sampler run compiled (:mod:`solver.planning._paper_loop`, :mod:`solver.planning._goal_stream`);
    ``compiled`` False runs both in Python, the same run (the reference the tests compare with)."""
    fixed = tuple(fixed)
    try:
        problem = problem_for_chain(chain, goal, fixed=fixed, shrink=shrink)
    except UnreachableGoalError:  # the target itself is fixed: no goal state can exist
        return Attempt(fixed, shrink, False, judge=SECOND_JUDGE, goals=GoalAccount(0, 0, 0, False, False))
    problem = count_checks(problem)
    goals = GoalSampler(problem, stable_seed("second judge goals", seed), SECOND_JUDGE_GOALS, compiled=compiled)
    planner = LaRrt(problem, np.random.default_rng(seed), SECOND_JUDGE_SETTINGS, goals, compiled_loop=compiled)
    # No clock: the run ends on its checks (an infinite time limit is never reached).
    recorder = AnytimeRecorder(SECOND_JUDGE, problem, math.inf, math.inf, budget)
    goals.bind(recorder)
    result = planner.solve(recorder, until_first=True)
    path = chain_path(problem, result.path) if result.solved else ()
    return Attempt(fixed, shrink, result.solved, path, result.checks, SECOND_JUDGE, goals.account())


def question_seed(chain: KinematicChain, fixed: Sequence[str]) -> int:
    """A seed for the second judge from the question itself (the chain and the objects fixed): the
    same question gets the same run in any process, and it draws nothing from the Maker's rng."""
    digest = hashlib.sha256(repr((chain, tuple(fixed))).encode()).hexdigest()
    return stable_seed("second judge", digest)


@dataclass(frozen=True)
class Necessity:
    """The judges' verdict on a group of objects fixed together."""

    necessary: bool
    margin: float  # the largest rung at which the puzzle stayed unsolved; 0 when not necessary
    queries: int  # the first judge's queries
    witness: Attempt | None = None  # the solved attempt at the required margin, when not necessary
    attempts: tuple[Attempt, ...] = ()  # every run, both judges, in the order made
    second_checks: int = 0  # the second judge's checks

    @property
    def reason(self) -> str:
        """:data:`NO_GOAL_STATE` or :data:`NO_PATH` when necessary (from the second judge's run at the
        measured margin; :data:`NO_PATH` when no second judge ran); "solved by <judge>" when not."""
        if not self.necessary:
            return f"solved by {self.witness.judge}" if self.witness is not None else "solved"
        last = self.attempts[-1] if self.attempts else None
        if last is not None and last.judge == GEOMETRY:
            return "the target's goal out of reach by geometry"
        if last is not None and last.goals is not None and last.goals.states == 0:
            return NO_GOAL_STATE
        return NO_PATH

    @property
    def how(self) -> str | None:
        """How a necessary verdict was reached, for the puzzle's record: :data:`~phyrogen_core.maker.BY_GEOMETRY`
        (a proof), :data:`~phyrogen_core.maker.BY_GOAL_SAMPLER` (the second judge's goal sampler found no
        goal state) or :data:`~phyrogen_core.maker.BY_SEARCH` (goal states, or no second judge, and no
        path within the budgets); None when not necessary."""
        if not self.necessary:
            return None
        reason = self.reason
        return BY_SEARCH if reason == NO_PATH else BY_GOAL_SAMPLER if reason == NO_GOAL_STATE else BY_GEOMETRY

    def describe(self) -> str:
        """One line: the verdict, its reason and the goal accounting behind it."""
        last = self.attempts[-1] if self.attempts else None
        goals = f"; second judge: {last.goals.describe()}" if last is not None and last.goals is not None else ""
        return f"{'necessary' if self.necessary else 'superfluous'} ({self.reason}){goals}"


def judge(chain: KinematicChain, goal: Goal, fixed: Sequence[str], margin: float, budget: int,
          rng: np.random.Generator, *, second_budget: int = 0, second_seed: int | None = None,
          proof: Callable[[float], bool] | None = None) -> Necessity:
    """Whether the objects ``fixed`` are necessary at ``margin``, and their measured margin.

    Rungs are tried from the top (:data:`MARGIN_LEVELS`); the first rung that neither judge solves
    is the measured margin. Solved at every rung down to ``margin`` itself: not necessary. The
    second judge runs only where the first failed, with ``second_budget`` checks (0: no second
    judge) and a seed from ``second_seed`` (default :func:`question_seed`); it never draws from
    ``rng``, so where it solves nothing the first judge's runs are what they were without it.

    ``proof(shrink)``, when given (with a second judge), is asked at the top rung *before* the first
    judge, and at a lower rung before the second judge: True (a geometric proof that the puzzle is
    unsolvable at that shrink, :class:`~solver.validation.blocking.BlockingProver`) settles the rung
    without a search. Both judges could only have failed there, so the verdict and the margin are
    what they were without the proof. At the top rung it spares the first judge's whole failing
    search (most of a Grid World puzzle's time), which would have drawn from ``rng`` (the validator's
    stream, not the Maker's): a later search of the validator that draws from it (RRT-Connect where
    no certificate extends, the certificate's repair, a later question's first judge) then draws
    other numbers than without the proof, and can find another certificate, measure another margin
    or accept another candidate; every verdict is still both judges' or a proof's
    (docs/performance.md says how often puzzles changed). Below the top rung the proof is asked
    only after the first judge failed, so it changes no draw.
    """
    queries = second_checks = 0
    attempt = None
    attempts: list[Attempt] = []
    levels = MARGIN_LEVELS if margin > 0 else (1,)
    for level in levels:
        # Reaching the required rung means the puzzle was solved at every rung above it: the
        # objects block by a sliver at most, and a verdict there needs a longer search.
        scale = MARGINAL_BUDGET_SCALE if level == levels[-1] and len(levels) > 1 else 1
        asked = level == levels[0] and second_budget and proof is not None  # the top rung: before the first judge
        if asked and proof(level * margin):
            attempts.append(Attempt(tuple(fixed), level * margin, False, judge=GEOMETRY))
            return Necessity(True, level * margin, queries, None, tuple(attempts), second_checks)
        attempt = attempt_fixed(chain, goal, fixed, level * margin, budget * scale, rng)
        attempts.append(attempt)
        queries += attempt.queries
        if not attempt.solved and second_budget and not asked and proof is not None and proof(level * margin):
            attempt = Attempt(tuple(fixed), level * margin, False, judge=GEOMETRY)
            attempts.append(attempt)
        elif not attempt.solved and second_budget:
            if second_seed is None:  # (a repr of the chain: not paid where no second judge runs)
                second_seed = question_seed(chain, fixed)
            attempt = attempt_second(chain, goal, fixed, level * margin, second_budget * scale,
                                     stable_seed(second_seed, level))
            attempts.append(attempt)
            second_checks += attempt.queries
        if not attempt.solved:
            return Necessity(True, level * margin, queries, None, tuple(attempts), second_checks)
    return Necessity(False, 0.0, queries, attempt, tuple(attempts), second_checks)


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
    attempt_second(chain, goal, [], 0.0, 200, 0)  # the second judge's compiled loop and goal sampler
