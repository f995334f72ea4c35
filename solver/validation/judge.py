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

Where both failed at a rung (and no proof settled it), a third, the staged judge
(:mod:`solver.validation.staged`, :func:`attempt_staged`), must fail too: the free objects moved one at a
time until they collide, then the target straight to its goal, with no random draws. It catches paths
that thread a sliver random states seldom land in (Continuous Space 4410009).

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
from solver.planning.problem import (
    FINE_RESOLUTION,
    Path,
    Problem,
    UnreachableGoalError,
    chain_path,
    path_is_valid,
    problem_for_chain,
    segment_points,
)
from solver.validation._repair_screen import screen
from solver.validation.staged import STAGED, staged_solution

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
WARM_RESTARTS = 8
"""Warm-started runs (:func:`attempt_warm`, on seeds of their own) at the required margin where the rung above
was solved, before both judges' longer searches (:func:`judge`), each with a :data:`WARM_SHARE` of the rung's base
budget (together 2x that budget, against the judges' 8x each). A failed search of LA-RRT is heavy-tailed: on a sliver
blocker a run either solves soon or wanders for tens of thousands of queries (Continuous Space 9940007: of 10
cold runs of the first judge, 3 unsolved at 100 000 queries, 7 solved within 11 400), and most warm runs that
solve do it by mending the rung above's path, within a few hundred queries, so many short runs, each with its
own draws, miss less often than a few long ones (on 8 marginal questions, 8 seeds each: 8 runs of 1000
queries solved 41 of 64, 4 runs of 4000 39, at 0.47x the queries; docs/generators.md#interlock-margin)."""
WARM_SHARE = 0.25
"""The share of the rung's base budget each warm-started run may spend."""
GOAL_REPAIR_SCALES = (0.5, 1.0, 2.0, 4.0)
"""Sizes of the moves, in shrinks of metres of motion, tried in turn to find a valid goal state near the rung
above's (:func:`goal_repair`)."""
GOAL_REPAIR_DRAWS = 512
"""Goal states checked a batch in :func:`goal_repair`."""
SHIFT_REPAIR_POINTS = 24
"""Points of a colliding run of the rung above's witness checked per offset before the run is checked whole
(:func:`shift_repair`)."""
GOAL_REPAIR_ROOTS = 8
"""Goal roots :func:`goal_repair` gives at most: the valid goal states of a batch can lie in pockets of slack
apart, of which only one may connect."""
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
WARM_JUDGE = "la_rrt_push_warm"
"""The first judge warm-started from the rung above's solution (:func:`attempt_warm`)."""
CARRIED = "carried"
"""The rung above's solution, holding as it stands at a lower rung (:func:`attempt_carried`)."""
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


def attempt_carried(chain: KinematicChain, goal: Goal, fixed: Sequence[str], shrink: float, witness: Path
                    ) -> Attempt | None:
    """``witness`` (a solution with the same objects fixed and the shapes shrunk more) as a solution at
    ``shrink``, where every motion of it holds there at the first judge's resolution, as the first judge's own
    solutions do; else None. One collision query."""
    if not witness:
        return None
    fixed = tuple(fixed)
    problem = problem_for_chain(chain, goal, fixed=fixed, shrink=shrink)
    columns = [chain.joint_order.index(name) for name in problem.model.joint_order]
    states = np.ascontiguousarray(np.asarray(witness, dtype=np.float64)[:, columns])
    if not (problem.model.check_prepared(states[:1]).all() and  # (the start: path_is_valid assumes it valid)
            path_is_valid(problem.model, states, problem.model.motion_steps(JUDGE_SETTINGS.resolution))):
        return None
    return Attempt(fixed, shrink, True, witness, 1, CARRIED)


def witness_points(problem: Problem, chain: KinematicChain, witness: Path) -> tuple[np.ndarray, ...]:
    """``witness`` in ``problem``'s joint order, its points every :data:`FINE_RESOLUTION`, the segment of each
    point and which points are valid: what :func:`witness_nodes` starts from, the same for every warm restart."""
    columns = [chain.joint_order.index(name) for name in problem.model.joint_order]
    states = np.ascontiguousarray(np.asarray(witness, dtype=np.float64)[:, columns])
    points, segment = segment_points(states, problem.model.motion_steps(FINE_RESOLUTION))
    return states, points, segment, problem.model.check_prepared(points)


def witness_nodes(problem: Problem, chain: KinematicChain, witness: Path, shrink: float, rng: np.random.Generator,
                  dense: tuple[np.ndarray, ...] | None = None
                  ) -> tuple[np.ndarray | tuple[tuple[np.ndarray, np.ndarray], ...], int]:
    """A warm start from ``witness`` (a path in ``chain``'s joint order, found where shapes were shrunk more) and
    the collision queries spent: a solution in ``problem``'s joint order where the witness holds in ``problem``
    as it stands (checked every :data:`~solver.planning.problem.FINE_RESOLUTION`) or once its colliding runs are
    moved (:func:`shift_repair`); else the trees' first nodes, as (states, parents) per tree
    (:func:`~solver.planning.la_rrt.la_rrt_within`): the start tree holds the witness's states up to its first
    colliding point, the goal tree those from its goal state back to its last colliding point, or, where the
    goal state itself collides, valid goal states near it (:func:`goal_repair`), if any are found."""
    states, points, segment, free = dense if dense is not None else witness_points(problem, chain, witness)
    if free.all():
        return states, 1
    repaired, queries = shift_repair(problem, np.vstack([states[:1], points]), np.r_[True, free], shrink, rng)
    if repaired is not None:
        return repaired, 1 + queries
    first, last = int(np.argmin(free)), len(free) - 1 - int(np.argmin(free[::-1]))
    ends = np.flatnonzero(np.diff(segment, append=len(states)))  # the points that are the witness's states
    start = points[_chain([e for e in ends if e < first], first - 1)]
    start_tree = (start, np.arange(len(start)))  # each after the one before, the first after the start (node 0)
    if free[-1]:
        goal = points[_chain([e for e in ends[::-1] if e > last], last + 1)]
        return (start_tree, (goal, np.arange(len(goal)) - 1)), 1 + queries
    roots, more = goal_repair(problem, points[-1], shrink, rng)
    return (start_tree, (roots, np.full(len(roots), -1))), 1 + queries + more


def _chain(waypoints: list[int], end: int) -> list[int]:
    """``waypoints`` then ``end`` (where valid points end), ``end`` not twice; no negative index."""
    return [int(e) for e in waypoints] + ([end] if end >= 0 and (not waypoints or waypoints[-1] != end) else [])


def shift_repair(problem: Problem, points: np.ndarray, free: np.ndarray, shrink: float,
                 rng: np.random.Generator) -> tuple[np.ndarray | None, int]:
    """The path ``points`` (dense, from the start to a goal state; ``free`` says which are valid in ``problem``)
    with each run of colliding points moved as one, by the same offset, so that it holds (checked at
    :data:`~solver.planning.problem.FINE_RESOLUTION` with the motions into and out of it), or None where some
    run finds no such offset; and the batches checked. Offsets are normal draws as in :func:`goal_repair` (the
    goal joints kept where a run reaches the goal), :data:`SHIFT_REPAIR_POINTS` points of a run screened per
    draw, the nearest offsets that pass checked whole."""
    reach = np.maximum(problem.model.joint_reach(), 1e-9)
    steps = problem.model.motion_steps(FINE_RESOLUTION)
    points, queries = points.copy(), 0
    edges = np.flatnonzero(np.diff(np.r_[True, free, True].astype(np.int8)))
    for a, b in zip(edges[::2], edges[1::2] - 1, strict=True):  # a run of colliding points a..b
        moved = np.ones(points.shape[1], dtype=bool)
        if b == len(points) - 1:
            moved[list(problem.goal_columns)] = False
        screened = points[np.unique(np.linspace(a, b, SHIFT_REPAIR_POINTS).astype(np.int64))]
        for scale in GOAL_REPAIR_SCALES:
            offsets = rng.standard_normal((GOAL_REPAIR_DRAWS, len(moved))) * (scale * max(shrink, FINE_RESOLUTION)
                                                                             / reach) * moved
            queries += 1
            # Each draw's screened points checked in turn, the run's middle point first, until one fails
            # (_repair_screen): the draws that pass are those passing every point, at a fraction of the checks.
            passed = _screen(problem, screened, offsets)
            found = None
            for k in np.flatnonzero(passed)[np.argsort(np.abs(offsets[passed] * reach).sum(axis=1), kind="stable")][:4]:
                run = np.vstack([points[a - 1:a], points[a:b + 1] + offsets[k], points[b + 1:b + 2]])
                queries += 1
                if np.all((run >= problem.lower) & (run <= problem.upper)) and \
                        path_is_valid(problem.model, np.ascontiguousarray(run), steps):
                    found = k
                    break
            if found is not None:
                points[a:b + 1] += offsets[found]
                break
        else:
            return None, queries
    return points, queries


def _screen(problem: Problem, points: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Which ``offsets`` keep every row of ``points`` within the limits of ``problem`` and collision-free."""
    model = problem.model
    return screen(np.ascontiguousarray(points, dtype=np.float64), np.ascontiguousarray(offsets, dtype=np.float64),
                  np.asarray(problem.lower, dtype=np.float64), np.asarray(problem.upper, dtype=np.float64),
                  *model._arguments)


def goal_repair(problem: Problem, state: np.ndarray, shrink: float,
                rng: np.random.Generator) -> tuple[np.ndarray, int]:
    """Valid goal states near ``state`` (a goal state that collides in ``problem``), at most
    :data:`GOAL_REPAIR_ROOTS` of them, nearest first, and the batches checked: :data:`GOAL_REPAIR_DRAWS` states a
    batch, the free joints moved by normal draws of ``scale`` times ``shrink`` (that of ``problem``) in metres of
    motion (:meth:`~solver.collision.model.CollisionModel.joint_reach`), for each scale of
    :data:`GOAL_REPAIR_SCALES` until a batch has a valid state. The rung above's goal state cleared every shape
    shrunk by twice this shrink, so a goal state of this rung, if there is one near it, lies about a shrink away
    in motion: where a sliver of slack is left, it is here."""
    reach = np.maximum(problem.model.joint_reach(), 1e-9)
    moved = np.ones(len(state), dtype=bool)
    moved[list(problem.goal_columns)] = False
    for k, scale in enumerate(GOAL_REPAIR_SCALES, start=1):
        offsets = rng.standard_normal((GOAL_REPAIR_DRAWS, len(state))) * (scale * max(shrink, FINE_RESOLUTION) / reach)
        candidates = np.ascontiguousarray(np.clip(state + offsets * moved, problem.lower, problem.upper))
        valid = np.flatnonzero(problem.model.check_prepared(candidates))
        if len(valid):
            order = valid[np.argsort(np.abs((candidates[valid] - state) * reach).sum(axis=1), kind="stable")]
            return candidates[order[:GOAL_REPAIR_ROOTS]], k
    return np.empty((0, len(state))), len(GOAL_REPAIR_SCALES)


def attempt_warm(chain: KinematicChain, goal: Goal, fixed: Sequence[str], shrink: float, budget: int,
                 rng: np.random.Generator, witness: Path, dense: tuple[np.ndarray, ...] | None = None) -> Attempt:
    """The first judge warm-started from ``witness``, a solution found with the same objects fixed and the
    shapes shrunk more (:func:`witness_nodes`): where the witness collides only by a sliver, the trees start
    on both sides of the sliver. The witness itself where it holds as it stands."""
    fixed = tuple(fixed)
    problem = problem_for_chain(chain, goal, fixed=fixed, shrink=shrink)
    nodes, spent = witness_nodes(problem, chain, witness, shrink, rng, dense)
    if isinstance(nodes, np.ndarray):  # the witness repaired: a solution
        return Attempt(fixed, shrink, True, chain_path(problem, nodes), spent, WARM_JUDGE)
    result, queries = la_rrt_within(problem, max(budget - spent, 0), rng, JUDGE_SETTINGS, nodes=nodes)
    path = chain_path(problem, result.path) if result.solved else ()
    return Attempt(fixed, shrink, result.solved, path, queries + spent, WARM_JUDGE)


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


def attempt_staged(chain: KinematicChain, goal: Goal, fixed: Sequence[str], shrink: float) -> Attempt:
    """The staged judge's try (:func:`~solver.validation.staged.staged_solution`), its path valid at
    :data:`FINE_RESOLUTION` and at the first judge's resolution (so that it carries as the first judge's do)."""
    path, queries = staged_solution(chain, goal, fixed, shrink, (FINE_RESOLUTION, JUDGE_SETTINGS.resolution))
    return Attempt(tuple(fixed), shrink, bool(path), path, queries, STAGED)


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
        last = self._deciding
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

    @property
    def _deciding(self) -> Attempt | None:
        """The last run other than a warm start's or the staged judge's (those only ever solve; a verdict's reason
        is the searching judges' or the proof's)."""
        return next((a for a in reversed(self.attempts) if a.judge not in (WARM_JUDGE, STAGED)), None)

    def describe(self) -> str:
        """One line: the verdict, its reason and the goal accounting behind it."""
        last = self._deciding
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

    Below the top rung, the rung above's solution is tried first as it stands (:func:`attempt_carried`): a
    path that holds at this rung's shrink at the first judge's resolution solves it, with no search.

    At the required margin, reached only by objects solved at the rung above (the marginal rung), the
    :data:`WARM_RESTARTS` warm-started runs from the rung above's solution (:func:`attempt_warm`: that path
    mended where it collides by a sliver, or the trees grown from both sides of the sliver), on seeds of their
    own, each with a :data:`WARM_SHARE` of ``budget``, run *before* the judges' long searches: they never draw
    from ``rng``, and the first of them mends most slivers in a few hundred queries. Only where none solves do
    the first judge (``budget`` times :data:`MARGINAL_BUDGET_SCALE`) and the second run, as they did before, so
    a necessary verdict rests on the same searches with the same budgets, and its reason stays the judges'.

    Where every search at a rung failed and no proof settled it, with a second judge, the staged judge
    (:func:`attempt_staged`: blockers moved one at a time until they collide, then the target straight to its goal;
    no draws, a few queries) must fail too before the rung counts as unsolved; where it solves, the rung is solved.

    ``proof(shrink)``, when given (with a second judge), is asked at every rung *before* any search, and
    asked again (the prover then tries finer cells, :meth:`~solver.validation.blocking.BlockingProver.proves`)
    after the first warm restart failed at the marginal rung and after the first judge failed elsewhere: True
    (a geometric proof that the puzzle is unsolvable at that shrink) settles the rung without a search. Both
    judges could only have failed there, so the verdict and the margin are what they were without the proof.
    A proof, a carried path or a warm restart that spares the first judge's search spares its draws from
    ``rng`` (the validator's stream, not the Maker's): a later search of the validator that draws from it
    (RRT-Connect where no certificate extends, the certificate's repair, a later question's first judge) then
    draws other numbers, and can find another certificate, measure another margin or accept another
    candidate; every verdict is still both judges' or a proof's (docs/performance.md says how often puzzles
    changed).
    """
    queries = second_checks = 0
    attempt = above = None
    attempts: list[Attempt] = []
    levels = MARGIN_LEVELS if margin > 0 else (1,)
    proving = bool(second_budget) and proof is not None
    for level in levels:
        # Reaching the required rung means the puzzle was solved at every rung above it: the
        # objects block by a sliver at most, and a verdict there needs a longer search.
        scale = MARGINAL_BUDGET_SCALE if level == levels[-1] and len(levels) > 1 else 1
        if above is not None:  # the rung above's solution, where it holds here as it stands
            carried = attempt_carried(chain, goal, fixed, level * margin, above.path)
            if carried is not None:
                attempts.append(carried)
                queries += carried.queries
                attempt = above = carried
                continue
        # The proof before any search; asked again (finer cells, :meth:`BlockingProver.proves`) before the
        # marginal rung's long searches, and after a failed search elsewhere.
        if proving and proof(level * margin):
            attempts.append(Attempt(tuple(fixed), level * margin, False, judge=GEOMETRY))
            return Necessity(True, level * margin, queries, None, tuple(attempts), second_checks)
        marginal = scale > 1 and above is not None and bool(second_budget)
        if marginal:
            # The warm restarts before the long searches: they draw nothing from rng, and the first mends most
            # slivers in a few hundred queries; the proof's finer cells only where it did not.
            if second_seed is None:
                second_seed = question_seed(chain, fixed)
            warm = _warm_restarts(chain, goal, fixed, level * margin, max(1, int(budget * WARM_SHARE)), second_seed,
                                  above.path, proof=proof if proving else None)
            attempts.extend(warm)
            queries += sum(a.queries for a in warm)
            if warm[-1].judge == GEOMETRY:
                return Necessity(True, level * margin, queries, None, tuple(attempts), second_checks)
            if warm[-1].solved:
                attempt = above = warm[-1]
                continue
        attempt = attempt_fixed(chain, goal, fixed, level * margin, budget * scale, rng)
        attempts.append(attempt)
        queries += attempt.queries
        if not attempt.solved and proving and not marginal and proof(level * margin):
            attempt = Attempt(tuple(fixed), level * margin, False, judge=GEOMETRY)
            attempts.append(attempt)
        elif not attempt.solved and second_budget:
            if second_seed is None:  # (a repr of the chain: not paid where no second judge runs)
                second_seed = question_seed(chain, fixed)
            attempt = attempt_second(chain, goal, fixed, level * margin, second_budget * scale,
                                     stable_seed(second_seed, level))
            attempts.append(attempt)
            second_checks += attempt.queries
        if not attempt.solved and attempt.judge != GEOMETRY and second_budget:
            # The staged judge last, only where every search failed: it draws nothing, so bytes change only where
            # it solves, i.e. where the searches' verdict at this rung was wrong (Continuous Space 4410009). With
            # no second judge (a caller's "first judge alone") it stays out too.
            staged = attempt_staged(chain, goal, fixed, level * margin)
            attempts.append(staged)
            queries += staged.queries
            if staged.solved:
                attempt = staged
        if not attempt.solved:
            return Necessity(True, level * margin, queries, None, tuple(attempts), second_checks)
        above = attempt
    return Necessity(False, 0.0, queries, attempt, tuple(attempts), second_checks)


def _warm_restarts(chain: KinematicChain, goal: Goal, fixed: Sequence[str], shrink: float, budget: int, seed: int,
                   witness: Path, proof: Callable[[float], bool] | None = None) -> list[Attempt]:
    """Up to :data:`WARM_RESTARTS` runs of :func:`attempt_warm` from ``witness``, ``budget`` queries each, each
    on its own seed from the question's ``seed``, until one solves: every run made. ``proof``, when given, is
    asked after the first run fails; where it holds, a :data:`GEOMETRY` attempt ends the list."""
    runs: list[Attempt] = []
    dense = witness_points(problem_for_chain(chain, goal, fixed=tuple(fixed), shrink=shrink), chain, witness)
    for k in range(WARM_RESTARTS):
        rng = np.random.default_rng(stable_seed(seed, "warm", k))
        runs.append(attempt_warm(chain, goal, fixed, shrink, budget, rng, witness, dense))
        if runs[-1].solved:
            break
        if k == 0 and proof is not None and proof(shrink):
            runs.append(Attempt(tuple(fixed), shrink, False, judge=GEOMETRY))
            break
    return runs


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
