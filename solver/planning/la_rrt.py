"""LA-RRT, the less-action RRT (Bayraktar et al., RA-L 2023), on our collision model.

The state space is factored: one factor per puzzle object (the columns of
the joints it moves). Two trees grow as in RRT-Connect, one from the start
and one from goal states (the target at its goal value, every other object
anywhere), and every tree edge moves exactly one factor: extending from a
node toward a sample walks a "staircase", moving the factors one after
another. Each time the trees connect, the path is defragmented
(:mod:`solver.planning.defragment`) and kept if it needs fewer actions; the loop runs
until the time limit (anytime, no rewiring).

Changes over the original implementation, in the default settings (bug
fixes of the original first, then additions of ours):

- the staircase visits the factors in a fresh random order at every
  extension (a fixed order stalls whenever the first factor is blocked at
  the start);
- defragmentation collapses an action to a straight segment only when that
  segment is valid;
- a trapped staircase keeps its valid prefix (every corner is a tree node);
- an extension moves one random factor only with probability 0.5, and a
  sampled joint sits at one of its limits with probability 0.1;
- distances are metres of motion, not joint units;
- goal roots also come from start-tree nodes with the target moved to its
  goal, and the start tree grows while there is none (uniform goal states of
  a lockbox are almost never valid);
- a move blocked only by other movable objects first pushes one of them
  aside (to a limit or a random value), the dependency every puzzle is built
  on; the original waits for sampling to move the blocker by chance.

These settings (:data:`PUSH_SETTINGS`, the defaults) are the benchmark's
"LA-RRT+push (ours)" and the Maker's necessity judge. The benchmark's
"LA-RRT" is :data:`PAPER_SETTINGS`: the algorithm as the paper and the
authors' code define it, with the bug fixes listed there. In the benchmark
both take their goal roots from the run's shared goal sampler
(:mod:`solver.planning.goal_sampling`, the ``goals`` argument of :class:`LaRrt`), as
every other planner does; without one (the judge) goal roots are drawn as
described above.

All random draws come from one numpy Generator seeded per run.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Protocol

import numpy as np

from solver.collision.kernels import nearest_l1
from solver.planning import _paper_loop
from solver.planning._isolated_step import compiled_piece as _compiled_piece
from solver.planning._isolated_step import factor_table, isolated_moves, step_arguments
from solver.planning.anytime import (
    AnytimeRecorder,
    Offer,
    PlanResult,
    count_checks,
)
from solver.planning.defragment import Defragmenter
from solver.planning.la_rrt_settings import (  # noqa: F401 (the settings, importable from here as before)
    EXTENSIONS,
    FACTOR_ORDERS,
    FIXED_ORDER_SETTINGS,
    GOAL_ROOT_RULES,
    PAPER_SETTINGS,
    PUSH_SETTINGS,
    SEGMENT_CHECK_SETTINGS,
    LaRrtSettings,
)
from solver.planning.problem import FINE_RESOLUTION, Problem, in_goal, path_is_valid, problem_factors
from solver.planning.tree_run import TreeRun

_REACHED, _ADVANCED, _TRAPPED = 0, 1, 2


class GoalSource(Protocol):
    """Where goal roots come from in the benchmark (:class:`solver.planning.goal_sampling.GoalSampler`)."""

    def next(self) -> np.ndarray | None:
        """A new valid goal state, or None when there are no more."""




class _Tree:
    """Nodes in a growing array, each with its parent (-1 for a root)."""

    def __init__(self, dimension: int, weights: np.ndarray):
        self.states = np.empty((256, dimension))
        self.parents = np.empty(256, dtype=np.int64)
        self.size = 0
        self.weights = weights

    def add(self, state: np.ndarray, parent: int) -> int:
        self.reserve(1)
        self.states[self.size] = state
        self.parents[self.size] = parent
        self.size += 1
        return self.size - 1

    def reserve(self, count: int) -> None:
        """Room for ``count`` more nodes (a compiled step writes its nodes into the arrays)."""
        while self.size + count > len(self.states):
            self.states = np.concatenate([self.states, np.empty_like(self.states)])
            self.parents = np.concatenate([self.parents, np.empty_like(self.parents)])

    def nearest(self, state: np.ndarray) -> int:
        return int(nearest_l1(self.states, self.size, state, self.weights))

    def branch(self, node: int) -> list[np.ndarray]:
        """States from the node's root to the node."""
        states = []
        while node >= 0:
            states.append(self.states[node])
            node = int(self.parents[node])
        return states[::-1]


class LaRrt(TreeRun):
    """One LA-RRT run on ``problem``."""

    def __init__(self, problem: Problem, rng: np.random.Generator, settings: LaRrtSettings | None = None,
                 goals: GoalSource | None = None, *, compiled_loop: bool = True):
        super().__init__(problem, rng, settings or LaRrtSettings(), goals)
        self.compiled_loop = compiled_loop  # the judges' paper run compiled where it applies (_paper_loop.applies)
        self.goal_draws = 0  # goal states asked of ``goals`` (the "half_tree" rule counts them)
        self.goal_states: list[np.ndarray] = []  # what ``goals`` gave, replayed in order after a restart
        self.restarts = 0
        self.factors = problem_factors(problem)
        self.columns = [np.asarray(c, dtype=np.int64) for c in self.factors.values()]
        self.factor_index = {name: i for i, name in enumerate(self.factors)}
        # Distances in metres of motion: a radian of a long bar counts as far as its tip travels.
        self.weights = self.model.joint_reach() if self.settings.weighted_metric else np.ones(len(problem.start))
        self.range = self.settings.range_fraction * float(self.weights @ (problem.upper - problem.lower))
        self.fine_steps = self.model.motion_steps(FINE_RESOLUTION)
        self.defragmenter = Defragmenter(problem, self.factors, self.steps)
        dimension = len(problem.start)
        self.start_tree = _Tree(dimension, self.weights)
        self.goal_tree = _Tree(dimension, self.weights)
        self.iterations = 0
        self.defragment_seconds = 0.0
        self.connections = 0
        self._compiled_step = self._compiled_step_arguments()

    def _compiled_step_arguments(self) -> tuple | None:
        """What the compiled isolated step needs beyond a step's own values; None where the Python step runs."""
        return step_arguments(self.settings, self.model, self.columns, self.steps)

    # -- sampling ----------------------------------------------------------
    def _draw(self, lower: np.ndarray, upper: np.ndarray, limit_probability: float) -> np.ndarray:
        """Uniform values in [lower, upper], each at a random one of its limits with ``limit_probability``."""
        n = len(lower)
        # One call for the three draws of n numbers each (uniform, at a limit?, which limit?):
        # the generator's stream is the same as with three calls, and a call costs more than n draws.
        u = self.rng.random(3 * n)
        values = lower + (upper - lower) * u[:n]
        at_limit = u[n:2 * n] < limit_probability
        if at_limit.any():
            values[at_limit] = np.where(u[2 * n:] < 0.5, upper, lower)[at_limit]
        return values

    def _sample(self) -> np.ndarray:
        """A state drawn with ``limit_probability``: passages in these puzzles tend to open at
        the limits (a slider pulled all the way out, a door slid to its end)."""
        return self._draw(self.problem.lower, self.problem.upper, self.settings.limit_probability)

    def _add_goal_root(self) -> bool:
        """Add one valid goal state as a new goal-tree root, if a batch of candidates holds one.

        With a goal source (the benchmark), its next state. Without one (the
        judge), uniform samples first; if none is valid, start-tree nodes with
        the target moved to its goal. In a lockbox a uniform goal state is valid
        only when every lock happens to be open (about 1 in 1e5), while a
        start-tree node that has opened them projects straight into the goal.
        """
        if self.goals is not None:
            self.goal_draws += 1
            if self.goal_draws <= len(self.goal_states):  # after a restart, the same roots again first
                state = self.goal_states[self.goal_draws - 1]
            else:
                state = self.goals.next()
                if state is None:
                    return False
                self.goal_states.append(state)
            self.goal_tree.add(state, -1)
            return True
        count = self.settings.goal_sample_attempts
        lower, upper = self.problem.lower, self.problem.upper
        uniform = lower + (upper - lower) * self.rng.random((count, len(lower)))
        projected = self.start_tree.states[self.rng.integers(0, self.start_tree.size, count)]
        for candidates in (uniform, projected):
            for column, value in self.problem.goal_columns.items():
                candidates[:, column] = value
            valid = self.model.check_prepared(candidates)
            first = int(valid.argmax())
            if valid[first]:
                self.goal_tree.add(candidates[first], -1)
                return True
        return False

    # -- extension ---------------------------------------------------------
    def _staircase(self, tree: _Tree, node: int, target: np.ndarray, budget: float,
                   single: bool = False) -> tuple[int, int]:
        """Move toward ``target`` one factor at a time (random order) within ``budget``;
        only the first factor of that order when ``single``. A move blocked by another
        movable object first pushes that object aside (:meth:`_push_blocker`); the pushed
        factor is then queued again, so that a connection still ends exactly at ``target``.

        Returns (status, last node added or ``node``)."""
        current = tree.states[node].copy()
        order = self._order(len(self.columns))
        queue = order[:1] if single else order
        pushes = 0
        moved: set[int] = set()
        while queue:
            f = queue.pop(0)
            columns = self.columns[f]
            delta = target[columns] - current[columns]
            distance = float(np.abs(delta) @ self.weights[columns])
            if distance <= 1e-12:
                continue
            partial = distance > budget
            values = current[columns] + delta * (budget / distance) if partial else target[columns]
            following = current.copy()
            following[columns] = values
            hit = self.model.motion_collision(current, following, self.steps)
            if hit >= 0:
                blocked = current + hit * (following - current)
                pushed = self._push_blocker(tree, node, current, f, values, blocked, moved) \
                    if pushes < self.settings.max_pushes else None
                if pushed is None:
                    return _TRAPPED, node
                node, current, blocker = pushed
                pushes += 1
                if not single and blocker not in queue:
                    queue.append(blocker)
                following = current.copy()
                following[columns] = values
            node = tree.add(following, node)
            current = following
            moved.add(f)
            if partial:
                return _ADVANCED, node
            budget -= distance
        return _REACHED, node

    def _push_blocker(self, tree: _Tree, node: int, current: np.ndarray, f: int, values: np.ndarray,
                      blocked: np.ndarray, moved: set[int]) -> tuple[int, np.ndarray, int] | None:
        """Free the move of factor ``f`` to ``values``, which collides at ``blocked``, by moving
        aside the movable object it hits there. Not tried when it hits anything static, nor
        when that object was ``moved`` already in this staircase (a push would undo the move).

        The blocker goes to one of a few candidate values (each joint at a
        random limit or uniform); the first that makes both its own move and
        the blocked one valid is added to the tree. This is the dependency the
        puzzles are built from (a door must move before the slider behind it),
        which plain sampling finds only by chance: in Move N Times the target
        crosses a sliding bar four times, each at a different bar position.
        Returns (new node, its state, blocker factor), or None.
        """
        columns = self.columns[f]
        hit = {name for pair in self.model.colliding_objects(blocked) for name in pair}
        blockers = [self.factor_index.get(name) for name in sorted(hit)]
        if None in blockers:
            return None
        blockers = [g for g in blockers if g != f and g not in moved]
        if not blockers:
            return None
        g = blockers[int(self.rng.integers(len(blockers)))]
        other = self.columns[g]
        lower, upper = self.problem.lower[other], self.problem.upper[other]
        for _ in range(self.settings.push_attempts):
            aside = current.copy()
            aside[other] = self._draw(lower, upper, 2 / 3)
            freed = aside.copy()
            freed[columns] = values
            # The blocked move first: the push itself can be long (a bar slid end to end).
            # A motion check assumes its start valid, so ``aside`` is checked on its own first.
            if self.model.is_valid(aside) and self.model.check_motion(aside, freed, self.steps) and \
                    self.model.check_motion(current, aside, self.steps):
                return tree.add(aside, node), aside, g
        return None

    def _isolate(self, tree: _Tree, node: int, target: np.ndarray) -> tuple[int, int]:
        """The original's extension: step from ``node`` toward ``target`` by at most the range, then
        move each factor that changed, one after another in a random order, to its value at the step's
        end; the moves are added only when all of them are valid. Returns (status, last node added or
        ``node``): reached when the step ends at ``target``."""
        current = tree.states[node]
        delta = target - current
        distance = float(np.abs(delta) @ self.weights)
        if distance <= 1e-12:
            return _REACHED, node
        reach = distance <= self.range
        end = target if reach else current + delta * (self.range / distance)
        if self._compiled_step is not None:
            tree.reserve(len(self.columns))  # (before the call: it may move the tree's arrays)
            counter, *arguments = self._compiled_step
            status, node, tree.size, checks = isolated_moves(self.rng, tree.states, tree.parents, tree.size, node,
                                                             end, bool(reach), *arguments)
            if counter is not None:
                counter.checks += checks
            return int(status), int(node)
        changed = [f for f, columns in enumerate(self.columns) if np.any(end[columns] != current[columns])]
        if self.settings.check_isolated_segment and len(changed) > 1 and \
                not self.model.check_motion(current, end, self.steps):
            return _TRAPPED, node
        corners = []
        state = current
        for k in self._order(len(changed)):
            columns = self.columns[changed[int(k)]]
            following = state.copy()
            following[columns] = end[columns]
            if not self.model.check_motion(state, following, self.steps):
                return _TRAPPED, node
            corners.append(following)
            state = following
        for corner in corners:
            node = tree.add(corner, node)
        return (_REACHED if reach else _ADVANCED), node

    def _order(self, count: int) -> list[int]:
        """The order in which ``count`` factors of a step move (:attr:`LaRrtSettings.factor_order`)."""
        if self.settings.factor_order == "fixed":
            return list(range(count))
        return [int(f) for f in self.rng.permutation(count)]

    def _connect_isolated(self, tree: _Tree, target: np.ndarray) -> tuple[int, int]:
        """RRT-Connect's connect with isolated steps: step from the nearest node toward ``target``
        until it is reached or a step is blocked."""
        status, node = _ADVANCED, -1
        while status == _ADVANCED:
            status, node = self._isolate(tree, tree.nearest(target), target)
        return status, node

    def _wants_goal_root(self) -> bool:
        if self.goal_tree.size == 0:
            return True
        if self.settings.goal_root_rule == "half_tree":
            return self.goal_draws < self.goal_tree.size // 2
        return self.rng.random() < self.settings.goal_root_probability

    def _path(self, tree: _Tree, node: int, other: _Tree, other_node: int) -> np.ndarray:
        a = tree.branch(node)
        b = other.branch(other_node)
        if tree is self.goal_tree:
            a, b = b, a
        return np.array(a + b[::-1][1:])

    # -- main loop ---------------------------------------------------------
    def solve(self, recorder: AnytimeRecorder, until_first: bool = False, *, benchmark: bool = False) -> PlanResult:
        """Grow the trees until ``recorder`` expires, or until the first solution when ``until_first``.

        ``benchmark`` (the benchmark's entries, :func:`plan_la_rrt`): every connection's path is
        defragmented before it is offered, the first one too (the original always defragments;
        :attr:`LaRrtSettings.defragment_share` may skip later ones), except with ``until_first``, where
        the first path is offered as found, as every benchmark planner's is; each must hold
        at fine resolution; one that clips restarts the search, as every benchmark planner does
        (docs/benchmark/README.md, "One restart rule"): fresh trees from the start, the random
        stream where it is, the goal roots drawn so far again in their order, iterations added up.

        Otherwise the Maker's judges' rule, which the compiled loops (:mod:`solver.planning._judge_loop`, and
        :mod:`solver.planning._paper_loop` for the second judge) mirror, so that generated puzzles do not
        change: with ``until_first`` the first raw path that holds at fine resolution is returned
        undefragmented; a clipped path is counted and the trees grow on; in limit mode each connection's
        raw path and then its defragmented form are offered."""
        problem = self.problem
        if not self.model.is_valid(problem.start):
            return recorder.result(0, "Invalid start")
        self.start_tree.add(problem.start, -1)
        if in_goal(problem, problem.start):
            recorder.offer([problem.start])
        elif _paper_loop.applies(self, recorder, until_first, benchmark):
            return _paper_loop.run(self, recorder)  # the same run, compiled (the second judge's)
        growing, other = self.start_tree, self.goal_tree
        isolate = self.settings.extension == "isolate"
        while not recorder.expired():
            self.iterations += 1
            if self._wants_goal_root():
                self._add_goal_root()
            recorder.sample(self.iterations)
            if self.goal_tree.size == 0:
                growing = self.start_tree  # grow it until a goal state is found
            sample = self._sample()
            near = growing.nearest(sample)
            if isolate:
                _, new = self._isolate(growing, near, sample)
            else:
                single = self.rng.random() < self.settings.single_factor_probability
                _, new = self._staircase(growing, near, sample, self.range, single)
            if new != near and other.size > 0:
                target = growing.states[new]
                if isolate:
                    status, reached = self._connect_isolated(other, target)
                else:
                    status, reached = self._staircase(other, other.nearest(target), target, math.inf)
                if status == _REACHED:
                    self.connections += 1
                    raw = self._path(growing, new, other, reached)
                    if until_first and not benchmark:
                        # Kept only if it holds at fine resolution, as the result's final check asks
                        # (segment by segment: a failing segment is found after a few states).
                        segments = zip(raw[:-1], raw[1:], strict=True)
                        if not all(self.model.check_motion(a, b, self.fine_steps) for a, b in segments):
                            recorder.clip()
                        elif recorder.offer(raw):
                            break
                    elif not benchmark:
                        self._offer_raw_and_defragmented(recorder, raw)
                    else:
                        # Until first, the first path is scored as found, as every planner's is
                        # (docs/benchmark/README.md, "Until first"); anytime, defragmented.
                        offer = recorder.offer_checked(raw) if until_first else \
                            self._offer_defragmented(recorder, raw)
                        if offer is Offer.BEST and until_first:
                            break
                        if offer is Offer.CLIPPED:
                            self._restart()
                            growing, other = self.start_tree, self.goal_tree
                            continue
            if self.goal_tree.size > 0:
                growing, other = other, growing
        return recorder.result(self.iterations)

    def _restart(self) -> None:
        """Fresh trees after a clipped path: every later connection through the clipping edge would
        clip too. The random stream goes on; the goal roots drawn so far come back in their order."""
        dimension = len(self.problem.start)
        self.start_tree = _Tree(dimension, self.weights)
        self.goal_tree = _Tree(dimension, self.weights)
        self.start_tree.add(self.problem.start, -1)
        self.goal_draws = 0
        self.restarts += 1

    def _offer_raw_and_defragmented(self, recorder: AnytimeRecorder, raw: np.ndarray) -> None:
        """The judges' rule: offer a connection's path, then (within the defragmenting share of the
        run) its defragmented form."""
        # Both checked at fine resolution before they count (Offer), so that a clipping path
        # never blocks an equally cheap one that holds.
        recorder.offer_checked(raw)  # a solution already; defragmenting improves it
        if not recorder.has_solution or \
                self.defragment_seconds < self.settings.defragment_share * recorder.usage():
            began = recorder.usage()
            recorder.offer_checked(self.defragmenter.run(raw, recorder.expired))
            self.defragment_seconds += recorder.usage() - began

    def _offer_defragmented(self, recorder: AnytimeRecorder, raw: np.ndarray) -> Offer:
        """Offer a connection's path defragmented (the first always; later ones within the
        defragmenting share of the run, else as found), checked at fine resolution (:class:`Offer`)."""
        # The share is measured in the unit that ends the run (checks under a check budget):
        # a budgeted run must not ask the clock what to do.
        if not recorder.has_solution or \
                self.defragment_seconds < self.settings.defragment_share * recorder.usage():
            began = recorder.usage()
            path = self.defragmenter.run(raw, recorder.expired)
            self.defragment_seconds += recorder.usage() - began
        else:
            path = raw
        return recorder.offer_checked(path)


def plan_la_rrt(problem: Problem, time_limit: float, seed: int, progress_interval: float = 0.1,
                settings: LaRrtSettings | None = None, *, until_first: bool = False, goal_seed: int | None = None,
                title: str = "LA-RRT", budget_checks: int | None = None,
                budget_cpu: float | None = None) -> PlanResult:
    """Run LA-RRT for ``time_limit`` seconds, or ``budget_checks`` collision checks (motions charged by
    their length) or ``budget_cpu`` CPU seconds with the time limit as a backstop (or until its first
    solution); its own draws from ``seed``, goal roots from the shared goal sampler seeded with
    ``goal_seed`` (default: from ``seed``)."""
    from solver.planning.goal_sampling import GoalSampler, default_goal_seed

    problem = count_checks(problem, by_length=True)
    goals = GoalSampler(problem, default_goal_seed(seed) if goal_seed is None else goal_seed)
    planner = LaRrt(problem, np.random.default_rng(seed), settings, goals)
    recorder = AnytimeRecorder(title, problem, time_limit, progress_interval, budget_checks, budget_cpu)
    return planner.solve(recorder, until_first, benchmark=True)


class _CountingModel:
    """A collision model that counts its queries: one per motion, one per batch of states
    (a batch is checked in one compiled call, like a motion)."""

    def __init__(self, model):
        self._model = model
        self.queries = 0

    def __getattr__(self, name):
        return getattr(self._model, name)

    def check_prepared(self, states):
        self.queries += 1
        return self._model.check_prepared(states)

    def motion_collision(self, start, end, steps):
        self.queries += 1
        return self._model.motion_collision(start, end, steps)

    def check_motion(self, start, end, steps):
        self.queries += 1
        return self._model.check_motion(start, end, steps)

    def colliding_objects(self, states):
        self.queries += 1
        return self._model.colliding_objects(states)


class _BudgetRecorder(AnytimeRecorder):
    """Expires after ``budget`` collision queries instead of seconds, so that the answer is
    the same on every machine."""

    def __init__(self, problem: Problem, model: _CountingModel, budget: int):
        super().__init__("LA-RRT", problem, math.inf, math.inf)
        self.model = model
        self.budget = budget

    def expired(self) -> bool:
        return self.model.queries >= self.budget

    def _holds(self, states: np.ndarray) -> bool:
        # One query where the path has a motion, as the counting model's batch of the path's fine points counted
        # it, checked by the model itself: path_is_valid's skipping check of the same points, the same verdict
        # at a fraction of the tests.
        self.model.queries += len(states) >= 2
        return path_is_valid(self.model._model, states, self.fine_steps)


def la_rrt_within(problem: Problem, budget: int, rng: np.random.Generator, settings: LaRrtSettings | None = None,
                  *, compiled: bool = True, nodes: tuple[tuple[np.ndarray, np.ndarray], ...] = ()
                  ) -> tuple[PlanResult, int]:
    """LA-RRT until its first solution or until ``budget`` collision queries are spent
    (deterministic: no clock decides anything). Returns the result and the queries spent.

    The run is the compiled loop of :mod:`solver.planning._judge_loop` where it applies
    (:func:`_compiled_loop_applies`) and ``compiled``; the same run either way. ``nodes`` (compiled loop
    only), a warm start: (states, parents) the start tree, then the goal tree, holds from the outset after the
    start (a parent is a node's index in its tree, the start 0 in the start tree; -1: a root, goal states only);
    each state valid, and each motion from its parent."""
    model = _CountingModel(problem.model)
    counted = replace(problem, model=model)
    planner = LaRrt(counted, rng, settings)
    recorder = _BudgetRecorder(counted, model, budget)
    if compiled and _compiled_loop_applies(planner.settings) \
            and problem.model.is_valid(problem.start) and not in_goal(problem, problem.start):
        return _compiled_run(planner, recorder, model, nodes), model.queries
    return planner.solve(recorder, until_first=True), model.queries


def _compiled_loop_applies(settings: LaRrtSettings) -> bool:
    """Whether the compiled judge loop runs these settings: staircase extensions, goal roots by
    probability, random factor order. The ablations' switches (fixed order, the isolated segment
    check) are Python only; the judge never uses them."""
    return settings.extension == "staircase" and settings.goal_root_rule == "probability" \
        and settings.factor_order == "random" and not settings.check_isolated_segment


COMPILED_PIECE_QUERIES = 2_000
"""Collision queries of one compiled call of the judge's loop: a fraction of a second even on the
largest puzzles, about 50 microseconds of Python between pieces."""


def _compiled_run(planner: LaRrt, recorder: _BudgetRecorder, model: _CountingModel, nodes=()) -> PlanResult:
    from solver.planning import _judge_loop

    problem, settings, real = planner.problem, planner.settings, model._model
    factor_columns, factor_sizes = factor_table(planner.columns)
    names = sorted({name for pair in real._pair_objects for name in pair})
    number = {name: i for i, name in enumerate(names)}
    pair_objects = np.array([(number[a], number[b]) for a, b in real._pair_objects], dtype=np.int64).reshape(-1, 2)
    object_factor = np.array([planner.factor_index.get(name, -1) for name in names], dtype=np.int64)
    goal_columns = np.array(list(problem.goal_columns), dtype=np.int64)
    goal_values = np.array(list(problem.goal_columns.values()), dtype=np.float64)
    # Nodes never outnumber queries, and one iteration adds at most this many beyond the budget.
    capacity = recorder.budget + 2 + 4 * (len(factor_sizes) + settings.max_pushes) + sum(len(p) for _, p in nodes)
    states, parents, sizes = _judge_loop.new_trees(np.ascontiguousarray(problem.start, dtype=np.float64), capacity)
    for tree, (given, parent) in enumerate(nodes):
        for state, up in zip(np.asarray(given, dtype=np.float64), parent, strict=True):
            _judge_loop._add(states, parents, sizes, tree, state, int(up))
    iterations, clipped, growing, other, queries = 0, 0, 0, 1, model.queries
    while True:
        # In pieces of COMPILED_PIECE_QUERIES: between them Python runs, so Ctrl-C and SIGTERM stop
        # the command at once; the pieces make the same run as one call (see _judge_loop.resume).
        stop = min(recorder.budget, queries + COMPILED_PIECE_QUERIES)
        path, iterations, queries, clipped, growing, other = _compiled_piece(
            _judge_loop.resume, planner.rng, states, parents, sizes, iterations, clipped, growing, other, stop,
            problem.lower, problem.upper, goal_columns, goal_values, planner.weights, planner.range, planner.steps,
            planner.fine_steps, factor_columns, factor_sizes, pair_objects, object_factor, settings.limit_probability,
            settings.single_factor_probability, settings.goal_root_probability, settings.goal_sample_attempts,
            settings.max_pushes, settings.push_attempts, queries, *real._arguments, real._pair_columns,
            real._shape_rho)
        if len(path) or queries >= recorder.budget:
            break
    model.queries = int(queries)
    recorder.clipped = int(clipped)
    if len(path) and not recorder.offer(path):
        raise RuntimeError("the compiled LA-RRT loop returned a path its recorder refuses")
    return recorder.result(int(iterations))
