"""ValidatePuzzle: can the target reach its goal? The Maker's validator on our collision model.

It extends the previous certificate when it can and otherwise runs OMPL's RRT-Connect
(:func:`solver.planning.ompl_setup.rrt_connect`); the problem itself, densifying and checking
certificates, and the dependency graph need no OMPL and live in :mod:`solver.planning.problem`.
The legs of a routed re-plan (Move N Times, :meth:`OmplValidator._replan_routed`), small problems of our
own factorisation, are searched by our own compiled RRT-Connect instead
(:func:`solver.planning._leg_connect.rrt_connect_leg`, written after OMPL's, its random numbers drawn from
the validator's numpy Generator); every other search, the main solve included, is OMPL's.

Budgets are counted in motion checks, never seconds, so the answer (and
therefore every generated puzzle) is the same on any machine. Each puzzle
seeds OMPL's seed generator at its start (:func:`~solver.planning.ompl_setup.seed_ompl`), and the goal
sampler draws from its own seeded numpy Generator.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from phyrogen_core.chain import KinematicChain
from phyrogen_core.maker import Necessary, SolveResult
from phyrogen_core.objects import PuzzleObject, build_chain
from phyrogen_core.puzzle import Goal
from solver.collision.model import DEFAULT_TOLERANCE, CollisionModel
from solver.planning._leg_connect import first_colliding_motion, rrt_connect_leg, shortcut
from solver.planning.defragment import defragment_certificate
from solver.planning.ompl_setup import rrt_connect
from solver.planning.problem import (
    DEFAULT_RESOLUTION,
    FINE_RESOLUTION,
    Problem,
    UnreachableGoalError,
    chain_path,
    collision_model,
    in_goal,
    path_is_valid,
    problem_for_chain,
    verify_certificate,
)
from solver.validation.blocking import BlockingProver
from solver.validation.judge import JUDGE_BUDGET, SECOND_JUDGE_BUDGET, Necessity, judge
from solver.validation.object_keys import ByObjects
from solver.validation.region_proof import proves as region_proves
from solver.validation.route_grid import Route, footprint, grid_path

DEFAULT_BUDGET = 4000
"""Collision queries (motion checks plus single-state checks) RRT-Connect may spend
before a puzzle counts as unsolved."""


CERTIFY_RETRY_SCALES = (4, 16)
"""Budget multiples (of the validator's budget) of the last re-plans from the certificate's last
fine-valid state when a re-plan at the validator's own budget finds no certificate at fine resolution."""

EXTENSION_GRID = 25
"""Evenly spaced values of a new joint tried when extending a previous certificate."""

ROUTE_CELL = 0.1
"""Metres between the workspace cells in which a routed re-plan finds the target's way."""
ROUTE_LEG = 1.0
"""Metres of route between the waypoints a routed re-plan plans to, one leg at a time."""
ROUTE_MARGIN = 0.5
"""Metres the target may stray from the cells of its route while it plans one leg."""
ROUTE_LEG_BUDGET = 20000
"""Collision queries RRT-Connect may spend on one leg of a routed re-plan (each retry: 4x more)."""
ROUTE_ALONE_BUDGET = 400
"""Collision queries for the first try at a leg: the target alone, everything else held. Of 1,975 legs
that try solved on fresh seeds (Move N Times n = 3 and 6), over 99.5 % took under 400 (median 6-8); a leg it
fails (the door in the way) then costs a fifth of the 2,000 it once did before every joint is searched."""
_ROUTE_YAWS = (0.0, math.pi / 4, math.pi / 2, 3 * math.pi / 4)


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

    ``routed`` (asked for by Move N Times) replaces RRT-Connect's search of
    the whole joint space after the previous certificate stops by a search
    along the target's route, one short leg at a time
    (:meth:`_replan_routed`). It finds other certificates than the default,
    so generators that do not ask for it keep their puzzles.
    """

    def __init__(self, rng: np.random.Generator, budget: int = DEFAULT_BUDGET,
                 resolution: float = DEFAULT_RESOLUTION, *, routed: bool = False):
        self.rng = rng
        self.budget = budget
        self.resolution = resolution
        self.routed = routed
        self.checks = 0
        self._solved: ByObjects = ByObjects()  # objects -> certificate (chain joint order)
        self._blocked: ByObjects = ByObjects()  # (target, *fixed) -> :meth:`_free_cells`' table
        self._fine: ByObjects = ByObjects()  # objects whose certificate was planned at fine resolution
        self.second_judge_budget = SECOND_JUDGE_BUDGET  # 0: the first judge alone (tests' controls)
        self.verdicts: list[Necessity] = []  # every necessity verdict, in the Maker's order
        self.prover: BlockingProver | None = BlockingProver()  # None: the judges alone (tests' controls)
        self._chains: dict[tuple[int, ...], tuple[tuple[PuzzleObject, ...], KinematicChain]] = {}

    def _chain(self, objects: tuple[PuzzleObject, ...]) -> KinematicChain:
        """``build_chain(objects)``, built once per puzzle state: the Maker asks the judges, the solve and
        the extension about the same objects (keyed by identity, the objects kept with their chain)."""
        key = tuple(map(id, objects))
        found = self._chains.get(key)
        if found is None:
            found = self._chains[key] = (objects, build_chain(objects))
        return found[1]

    def _problem(self, objects: tuple[PuzzleObject, ...], goal: Goal) -> Problem | None:
        """:func:`~solver.planning.problem.problem_for_objects` on the chain of :meth:`_chain`."""
        try:
            return problem_for_chain(self._chain(objects), goal)
        except UnreachableGoalError:
            return None

    def clean(self, objects: Sequence[PuzzleObject], goal: Goal, path) -> tuple[tuple[float, ...], ...]:
        """``path`` defragmented as a certificate is (the Maker checks a search's verdict against it)."""
        return defragment_certificate(build_chain(tuple(objects)), goal, path)

    def solve(self, objects: Sequence[PuzzleObject], goal: Goal, *, budget_scale: float = 1.0) -> SolveResult:
        objects = tuple(objects)
        problem = self._problem(objects, goal)
        if problem is None:
            return SolveResult(False)
        budget = int(self.budget * budget_scale)
        path = self._extend_previous(objects, goal, problem)
        if path is None:
            if self.routed:
                extended = self._previous_in(objects, problem)
                if extended is not None:
                    # Legs are short, so planning them at fine resolution costs little, and the
                    # certificate then needs no repair in certify (a repair re-plans everything after it).
                    path = self._replan_routed(objects, goal, problem, extended, FINE_RESOLUTION,
                                               self._new_objects_model(objects, problem))
                    if path is not None:
                        self._fine[objects] = True
            previous = self._previous_with_same_joints(objects) if path is None else None
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

    def _previous_in(self, objects: tuple[PuzzleObject, ...], problem: Problem):
        """The certificate of the longest solved prefix of ``objects`` with every joint added since
        held at its start value: a path of the new puzzle up to where the new objects block it."""
        prefix = self._solved_prefix(objects)
        if prefix is None:
            return None
        old_order = self._chain(objects[:prefix]).joint_order
        start = dict(zip(problem.model.chain.joint_order, chain_path(problem, [problem.start])[0], strict=True))
        rows = [dict(zip(old_order, state, strict=True)) for state in self._solved[objects[:prefix]]]
        return tuple(tuple(row.get(j, start[j]) for j in problem.model.chain.joint_order) for row in rows)

    def _replan_tail(self, problem: Problem, path, resolution: float, budget: int):
        """Factored validation: keep the longest prefix of ``path`` (chain joint order) that is
        collision-free at ``resolution`` and plan only the rest, from where it stops.

        When the new objects are walls the old certificate still holds up to the new walls, so
        only what lies past them is searched, though in the whole joint space (Move N Times'
        corridors cost about 2.5x per level this way; :meth:`_replan_routed` searches along a
        route instead). Returns None when no path is found within ``budget`` queries (the
        caller then plans from the start)."""
        prefix = self._valid_prefix(problem, path, resolution)
        if prefix is None:
            return None
        states, kept = prefix
        if kept == len(states) and in_goal(problem, states[-1]):
            return chain_path(problem, states)
        result = rrt_connect(replace(problem, start=states[kept - 1]), budget, self.rng, resolution)
        self.checks += result.checks
        if not result.solved:
            return None
        return chain_path(problem, np.concatenate([states[:kept - 1], np.array(result.path)]))

    def _valid_prefix(self, problem: Problem, path, resolution: float,
                      motions: CollisionModel | None = None) -> tuple[np.ndarray, int] | None:
        """``path`` in the problem's joint order and how many of its states lead from the start
        without collision at ``resolution``; None when it does not begin at the start. Its
        motions are checked with ``motions`` when given (a model of part of the puzzle, with the
        problem's joint order, that the path is known to clear everywhere else)."""
        model = problem.model
        columns = [model.chain.joint_order.index(j) for j in model.joint_order]
        states = np.asarray(path, dtype=np.float64)[:, columns]
        steps = model.motion_steps(resolution)
        if not model.is_valid(states[0]) or np.any(np.abs(states[0] - problem.start) > 1e-12):
            return None
        motions = model if motions is None else motions
        if type(motions) is CollisionModel:  # the same verdicts in the same order, in one compiled call
            first = first_colliding_motion(motions, np.ascontiguousarray(states), steps)
            kept = len(states) if first < 0 else first + 1
        else:
            kept = 1
            while kept < len(states) and motions.check_motion(states[kept - 1], states[kept], steps):
                kept += 1
        self.checks += kept
        return states, kept

    def _new_objects_model(self, objects: tuple[PuzzleObject, ...], problem: Problem) -> CollisionModel | None:
        """A model of the movable objects and the fixed ones added since the longest solved prefix
        of ``objects``, when that prefix's certificate holds at fine resolution and nothing movable
        was added: the only collisions that certificate can meet in the new puzzle are with these."""
        prefix = self._solved_prefix(objects)
        if prefix is None or objects[:prefix] not in self._fine or any(o.is_movable for o in objects[prefix:]):
            return None
        part = tuple(o for o in objects[:prefix] if o.is_movable) + objects[prefix:]
        model = collision_model(build_chain(part), problem.model.locked, problem.model.tolerance)
        return model if model.joint_order == problem.model.joint_order else None

    def _replan_routed(self, objects: tuple[PuzzleObject, ...], goal: Goal, problem: Problem, path,
                       resolution: float, motions: CollisionModel | None = None):
        """Factored validation along a route: keep the valid prefix of ``path`` (as
        :meth:`_replan_tail`), find the target's way from where it stops to its goal on a grid of
        workspace cells (every other movable object could step aside, so only fixed ones count),
        and plan the rest one leg of that route at a time, each within a window around its leg, with
        our compiled RRT-Connect (:mod:`solver.planning._leg_connect`), not OMPL's.

        Every leg is a small problem however large the puzzle is, so a new level of nested walls
        (Move N Times) costs about its length, not the volume of everything behind it. Returns
        None when there is no route or a leg fails even with a wider window and more budget.
        ``motions``: see :meth:`_valid_prefix`."""
        prefix = self._valid_prefix(problem, path, resolution, motions)
        if prefix is None:
            return None
        states, kept = prefix
        if kept == len(states) and in_goal(problem, states[-1]):
            return chain_path(problem, states)
        route = self._route(objects, goal, problem, states[kept - 1])
        if route is None:
            return None
        x, y = route.columns
        steps = problem.model.motion_steps(resolution)
        pieces = [states[:kept - 1]]
        current = states[kept - 1]
        for index, (cells, waypoint) in enumerate(route.legs):
            if index == len(route.legs) - 1:
                goal_columns, tolerance = problem.goal_columns, problem.tolerance
            else:
                goal_columns, tolerance = {x: waypoint[0], y: waypoint[1]}, ROUTE_CELL / 2
            leg_path = self._plan_leg(problem, route, current, cells, goal_columns, tolerance, resolution)
            if leg_path is None:
                return None
            leg_path = self._shortcut(problem.model, leg_path, steps)
            pieces.append(leg_path[:-1])
            current = leg_path[-1]
        return chain_path(problem, np.concatenate([*pieces, current[None, :]]))

    def _plan_leg(self, problem: Problem, route: Route, current: np.ndarray, cells: np.ndarray,
                  goal_columns: dict[int, float], tolerance: float, resolution: float) -> np.ndarray | None:
        """One leg of a routed re-plan (problem joint order), or None: the target alone first, every
        other joint held where it is (most legs need nothing else, and the certificate stays
        clean), then every joint, in a window around the leg that widens with each retry."""
        x, y = route.columns
        for attempt in range(3):
            margin = ROUTE_MARGIN * 2 ** attempt
            lower, upper = problem.lower.copy(), problem.upper.copy()
            for column, values in ((x, cells[:, 0]), (y, cells[:, 1])):
                lower[column] = max(lower[column], min(values.min(), current[column]) - margin)
                upper[column] = min(upper[column], max(values.max(), current[column]) + margin)
            if attempt == 0:
                alone = self._plan_target_alone(problem, route.target_columns, current, goal_columns, tolerance,
                                                lower, upper, resolution)
                if alone is not None:
                    return alone
            leg = replace(problem, start=current, goal_columns=goal_columns, tolerance=tolerance,
                          lower=lower, upper=upper)
            result = rrt_connect_leg(leg, ROUTE_LEG_BUDGET * 4 ** attempt, self.rng, resolution)
            self.checks += result.checks
            if result.solved:
                return np.array(result.path)
        return None

    def _plan_target_alone(self, problem: Problem, columns: tuple[int, ...], current: np.ndarray,
                           goal_columns: dict[int, float], tolerance: float, lower: np.ndarray,
                           upper: np.ndarray, resolution: float) -> np.ndarray | None:
        """RRT-Connect over the target's ``columns`` only, every other joint held at ``current`` (the
        puzzle's own model, those joints' limits pinned there); the path in the problem's joint order,
        or None."""
        if any(column not in columns for column in goal_columns):
            return None
        held = [i for i in range(len(current)) if i not in columns]
        sub = Problem(problem.model, current, goal_columns, lower, upper, tolerance)
        result = rrt_connect_leg(sub, ROUTE_ALONE_BUDGET, self.rng, resolution, held)
        self.checks += result.checks
        return np.array(result.path) if result.solved else None

    def _shortcut(self, model: CollisionModel, states: np.ndarray, steps: np.ndarray) -> np.ndarray:
        """``states`` with every state dropped that a straight motion from an earlier one can skip
        (greedily, farthest first): planner paths wander, and the stored certificate is cleaned
        in time that grows with its length."""
        if type(model) is CollisionModel:  # the same motions tried, their verdicts by skipping, in one compiled call
            kept, checks = shortcut(model, np.ascontiguousarray(states, dtype=np.float64), steps)
            self.checks += checks
            return kept
        kept, i = [0], 0
        while i < len(states) - 1:
            j = len(states) - 1
            while j > i + 1:
                self.checks += 1
                if model.check_motion(states[i], states[j], steps):
                    break
                j -= 1
            kept.append(j)
            i = j
        return states[kept]

    def _route(self, objects: tuple[PuzzleObject, ...], goal: Goal, problem: Problem, state: np.ndarray):
        """The target's way from its position in ``state`` to its goal position through the
        workspace cells where it clears every fixed object at one of a few yaws, cut into legs of
        about :data:`ROUTE_LEG`; None when the target is not a planar (x, y) object or no way exists."""
        target = next((o for o in objects if o.name == goal.target), None)
        if target is None or len(target.joint_names) < 2:
            return None
        names = target.joint_names
        order = problem.model.joint_order
        if names[0] not in order or names[1] not in order or (len(names) > 2 and names[2] not in order):
            return None
        x, y = order.index(names[0]), order.index(names[1])
        xs = np.arange(problem.lower[x], problem.upper[x] + 1e-9, ROUTE_CELL)
        ys = np.arange(problem.lower[y], problem.upper[y] + 1e-9, ROUTE_CELL)
        free = self._free_cells(target, tuple(o for o in objects if not o.is_movable), xs, ys)
        roomy = free.all(axis=2)
        free = free.any(axis=2)
        goal_xy = (goal.values.get(names[0], state[x]), goal.values.get(names[1], state[y]))
        ends = []
        for px, py in ((state[x], state[y]), goal_xy):
            distance = np.hypot(xs[:, None] - px, ys[None, :] - py)
            distance[~free] = np.inf
            cell = np.unravel_index(int(np.argmin(distance)), distance.shape)
            if not distance[cell] <= 2 * ROUTE_CELL:
                return None
            ends.append(cell)
        cells = grid_path(free, roomy, ends[0], ends[1])
        if cells is None:
            return None
        points = np.column_stack([xs[cells[:, 0]], ys[cells[:, 1]]])
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])
        count = max(1, int(math.ceil(along[-1] / ROUTE_LEG)))
        ends_at = [min(int(np.searchsorted(along, along[-1] * k / count)), len(points) - 1) for k in range(1, count)]
        ends_at.append(len(points) - 1)
        legs, begin = [], 0
        for end in ends_at:
            legs.append((points[begin:end + 1], points[end]))
            begin = end
        columns = tuple(order.index(name) for name in names if name in order)
        return Route((x, y), columns, legs)

    def _free_cells(self, target: PuzzleObject, fixed: tuple[PuzzleObject, ...], xs: np.ndarray,
                    ys: np.ndarray) -> np.ndarray:
        """(x, y, yaw) -> whether the target there clears every object of ``fixed``. Kept per
        prefix of ``fixed``: a puzzle that grows by walls checks only its new walls, and only
        the cells from which the target could reach them."""
        known = next(k for k in range(len(fixed), -1, -1) if (target, *fixed[:k]) in self._blocked or k == 0)
        clear = self._blocked.get((target, *fixed[:known]))
        if clear is None or clear.shape[:2] != (len(xs), len(ys)):
            clear, known = np.ones((len(xs), len(ys), len(_ROUTE_YAWS)), dtype=bool), 0
        if known == len(fixed):
            return clear
        clear = clear.copy()
        cells_x, cells_y, ok, checks = _walls_clear(target, fixed[known:], xs, ys)
        self.checks += checks
        if len(cells_x):
            clear[cells_x, cells_y] &= ok
        self._blocked[(target, *fixed)] = clear
        return clear

    def necessity(self, objects: Sequence[PuzzleObject], goal: Goal, fixed: Sequence[str], margin: float, *,
                  budget_scale: float = 1.0) -> Necessary | None:
        """The Maker's FixJoint: :func:`solver.validation.judge.judge`, both judges, with ``budget_scale``
        times :data:`~solver.validation.judge.JUDGE_BUDGET` and
        :data:`~solver.validation.judge.SECOND_JUDGE_BUDGET`; None when the objects ``fixed`` are
        superfluous, else their measured margin and how it was reached. Each verdict, with the judges'
        goal accounting, is kept in :attr:`verdicts`. (The budgets do not grow with :attr:`budget`:
        LA-RRT's pushes need no larger search where RRT-Connect does, as in Move N Times.) Where the
        first judge fails, :attr:`prover` is asked for a geometric proof before the second judge runs
        (:func:`~solver.validation.judge.judge`: the same verdicts and puzzles, the second judge's search saved)."""
        second = max(1, int(self.second_judge_budget * budget_scale)) if self.second_judge_budget else 0
        objects = tuple(objects)
        prover = self.prover
        proof = None if prover is None else (lambda shrink: region_proves(objects, goal, fixed, shrink) or
                                             prover.proves(objects, goal, fixed, shrink))
        verdict = judge(self._chain(objects), goal, fixed, margin, int(JUDGE_BUDGET * budget_scale), self.rng,
                        second_budget=second, proof=proof)
        self.checks += verdict.queries + verdict.second_checks
        self.verdicts.append(verdict)
        return Necessary(verdict.margin, verdict.how) if verdict.necessary else None

    def _extend_previous(self, objects: tuple[PuzzleObject, ...], goal: Goal, problem: Problem):
        """A certificate for ``objects`` built from one for a prefix of them, or None. ``problem`` is
        the puzzle's: its collision model is the whole chain's when it locks no joint (no new one built)."""
        prefix = self._solved_prefix(objects)
        if prefix is None:
            return None
        old_chain = self._chain(objects[:prefix])
        chain = self._chain(objects)
        new_joints = [j for j in chain.joint_order if j not in old_chain.joint_order]
        if len(new_joints) > 1:
            return None  # a grid over several new joints is not worth it; RRT-Connect decides
        whole = problem.model
        model = whole if not whole.locked and whole.tolerance == DEFAULT_TOLERANCE else collision_model(chain)
        # Candidates are screened at the validator's resolution (most parkings fail, and fail
        # fast there); the one kept must hold at fine resolution, as certificates do.
        coarse, fine = model.motion_steps(self.resolution), model.motion_steps(FINE_RESOLUTION)
        order = chain.joint_order
        # The old certificate's states with the new joints parked, after its start with them at 0.0.
        old = np.asarray(self._solved[objects[:prefix]], dtype=np.float64)
        old_columns = [order.index(j) for j in old_chain.joint_order]
        new_columns = [order.index(j) for j in new_joints]
        replayed = np.empty((len(old) + 1, len(order)))
        replayed[0, old_columns] = old[0]
        replayed[1:, old_columns] = old
        replayed[0, new_columns] = 0.0
        for value in _parking_values(chain, new_joints):
            path = replayed.copy()
            path[1:, new_columns] = value
            if not goal.is_reached(chain.state_dict(path[-1])):
                return None
            self.checks += len(path)
            if _first_colliding(model, path, coarse) < 0 and path_is_valid(model, path, fine):
                return tuple(tuple(float(v) for v in row) for row in path)
        return None

    def certify(self, objects: Sequence[PuzzleObject], goal: Goal, path, *, budget_scale: float = 1.0):
        """A certificate that holds at :data:`FINE_RESOLUTION`: ``path`` itself when it does,
        else a path planned again at that resolution (a path planned coarsely can clip a
        corner between two checked states). Returns None when none is found."""
        chain = self._chain(tuple(objects))
        if not verify_certificate(chain, path, goal):
            return tuple(path)
        # Most coarse paths clip a corner late or not at all: re-plan from the last fine-valid state first.
        problem = self._problem(tuple(objects), goal)
        if problem is not None and self.routed:
            repaired = self._replan_routed(tuple(objects), goal, problem, path, FINE_RESOLUTION)
            if repaired is not None and not verify_certificate(chain, repaired, goal):
                return repaired
        if problem is not None:
            repaired = self._replan_tail(problem, path, FINE_RESOLUTION, int(self.budget * budget_scale))
            if repaired is not None and not verify_certificate(chain, repaired, goal):
                return repaired
        fine = OmplValidator(self.rng, self.budget, FINE_RESOLUTION, routed=self.routed)
        result = fine.solve(objects, goal, budget_scale=budget_scale)
        self.checks += fine.checks
        if result.solved and not verify_certificate(chain, result.path, goal):
            return result.path
        # A coarse search can slip past a corner that a fine one has to find its way around, so a
        # fine search of the same budget can fail where the coarse one succeeded (Continuous Space:
        # about 1 seed in 300). Tried last, so every puzzle certified by a step above stays as it is.
        for scale in CERTIFY_RETRY_SCALES:
            if problem is None:
                break
            repaired = self._replan_tail(problem, path, FINE_RESOLUTION, int(self.budget * budget_scale * scale))
            if repaired is not None and not verify_certificate(chain, repaired, goal):
                return repaired
        return None


_WALLS_CLEAR: OrderedDict[tuple, tuple[np.ndarray, np.ndarray, np.ndarray, int]] = OrderedDict()
_WALLS_CLEAR_KEPT = 64


def _walls_clear(target: PuzzleObject, walls: tuple[PuzzleObject, ...], xs: np.ndarray,
                 ys: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The cells of the grid ``xs`` x ``ys`` from which the target could reach one of ``walls``, whether it
    clears them there at each of :data:`_ROUTE_YAWS` (cells, yaws), and the states checked. A function of
    the objects' geometry and the grid alone, so the last few answers are kept for the whole process,
    found by the objects' equality: Move N Times' walls and door track are the same on every seed, and a
    dataset's worker asks the same question for each of its puzzles. ``checks`` is counted by the caller
    on every call, kept or not, so a puzzle's query count does not depend on what the process made before."""
    key = (target, walls, xs.tobytes(), ys.tobytes())
    found = _WALLS_CLEAR.get(key)
    if found is not None:
        _WALLS_CLEAR.move_to_end(key)
        return found
    origin = np.asarray(target.pose.xyz[:2])
    outline = footprint(target)
    near = np.zeros((len(xs), len(ys)), dtype=bool)
    for obj in walls:
        points = footprint(obj)
        if points is None or outline is None:
            near[:] = True
            break
        reach = float(np.max(np.linalg.norm(outline - origin, axis=1))) + ROUTE_CELL
        low, high = points.min(axis=0) - origin - reach, points.max(axis=0) - origin + reach
        near |= ((xs >= low[0]) & (xs <= high[0]))[:, None] & ((ys >= low[1]) & (ys <= high[1]))[None, :]
    cells_x, cells_y = np.nonzero(near)
    count, yaws = len(cells_x), len(_ROUTE_YAWS)
    ok = np.ones((count, yaws), dtype=bool)
    if count:
        model = CollisionModel(build_chain((target, *walls)))
        names = target.joint_names
        values = {names[0]: np.repeat(xs[cells_x], yaws), names[1]: np.repeat(ys[cells_y], yaws)}
        if len(names) > 2:
            values[names[2]] = np.tile(_ROUTE_YAWS, count)
        states = np.column_stack([values[name] for name in model.joint_order])
        ok = model.check(states).reshape(count, yaws)
    found = (cells_x, cells_y, ok, count * yaws if count else 0)
    for array in found[:3]:
        array.flags.writeable = False  # shared by every puzzle that asks
    _WALLS_CLEAR[key] = found
    if len(_WALLS_CLEAR) > _WALLS_CLEAR_KEPT:
        _WALLS_CLEAR.popitem(last=False)
    return found


def _first_colliding(model: CollisionModel, states: np.ndarray, steps: np.ndarray) -> int:
    """``model.first_colliding_motion``'s answer, found by skipping when ``model`` is a plain CollisionModel."""
    if type(model) is CollisionModel:
        return first_colliding_motion(model, states, steps)
    return model.first_colliding_motion(states, steps)


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
