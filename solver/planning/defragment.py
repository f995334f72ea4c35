"""Path defragmentation (Bayraktar et al., RA-L 2023): fewer actions, same start and goal.

A path is held as a list of *actions*: (factor, waypoints), where each
waypoint gives only that factor's joint values. Replaying the list from the
start state copies the current state and overwrites the factor's columns, so
an action can be moved, merged or deleted and the rest of the path still
makes sense. Every candidate is accepted only if all its segments are
collision-free and it still ends in the goal; the operators repeat until
none improves the path:

- tail: drop the actions after the target's last move;
- collapse: make an action one straight segment (only when that segment is valid);
- merge: join two actions of one factor by replaying the later one right
  after the earlier one (or the earlier one right before the later one);
- skip: delete an action entirely.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np

from phyrogen_core.actions import factor_membership, moved_factors
from phyrogen_core.chain import KinematicChain
from phyrogen_core.puzzle import Goal
from solver.collision.model import CollisionModel
from solver.planning.problem import (
    DEFAULT_RESOLUTION,
    FINE_RESOLUTION,
    Problem,
    chain_path,
    in_goal,
    problem_factors,
    problem_for_chain,
    verify_certificate,
)

Action = tuple[int, tuple[np.ndarray, ...]]  # (factor index, waypoints of that factor's columns)

ISOLATE_SPLITS = 6
"""How often a multi-factor segment may be halved to find single-factor moves (at most 64 pieces)."""
MOVE_TOLERANCE = 1e-9
"""Stricter than :data:`phyrogen_core.actions.MOVE_TOLERANCE`: any change of a factor's joints makes it a move here."""


class Defragmenter:
    """Defragments paths of one problem; ``factors`` are the state columns of each object."""

    def __init__(self, problem: Problem, factors: Mapping[str, Sequence[int]], steps: np.ndarray,
                 max_rounds: int = 50):
        self.problem = problem
        self.model: CollisionModel = problem.model
        self.columns = [np.asarray(c, dtype=np.int64) for c in factors.values()]
        self.membership = factor_membership(factors, len(problem.start))
        self.goal_factors = {f for f, c in enumerate(self.columns) if set(c.tolist()) & set(problem.goal_columns)}
        self.steps = steps
        self.max_rounds = max_rounds
        self.validations = 0
        self._free: set[bytes] = set()  # motions (their two states' bytes) found free
        self._colliding: set[bytes] = set()  # motions found colliding

    # -- representation ----------------------------------------------------
    def isolate(self, path: np.ndarray) -> list[Action] | None:
        """Actions of ``path``; a segment moving several factors becomes one move per factor
        (:meth:`_staircase`). None when a segment cannot be made so."""
        states = [path[0]]
        moved_matrix = self.moved_factors(path)
        for k, (a, b) in enumerate(zip(path[:-1], path[1:], strict=True)):
            moved = np.flatnonzero(moved_matrix[k]).tolist()
            if len(moved) > 1:
                stair = self._staircase(a, b, moved, ISOLATE_SPLITS)
                if stair is None:
                    return None
                states += stair
            else:
                states.append(b)
        return self.actions_of(np.array(states))

    def _staircase(self, a: np.ndarray, b: np.ndarray, moved: list[int], splits: int) -> list[np.ndarray] | None:
        """Valid states after ``a`` that reach ``b`` moving one factor at a time: the factors in
        order, else in reverse order, else each half of the segment on its own (up to ``splits``
        halvings). A planner's diagonal segment through a narrow passage often has no valid
        staircase as a whole, but its short pieces do. None when there is none."""
        for order in (moved, moved[::-1]):
            stair = [a]
            for f in order:
                nxt = stair[-1].copy()
                nxt[self.columns[f]] = b[self.columns[f]]
                stair.append(nxt)
            if self._segments_valid(np.array(stair)):
                return stair[1:]
        if splits == 0:
            return None
        middle = (a + b) / 2
        if not self.model.is_valid(middle):
            return None
        first = self._staircase(a, middle, moved, splits - 1)
        second = None if first is None else self._staircase(middle, b, moved, splits - 1)
        return None if second is None else first + second

    def moved_factors(self, states: np.ndarray) -> np.ndarray:
        """(segments, factors) booleans: which factors each segment of ``states`` moves."""
        return moved_factors(states, self.membership, MOVE_TOLERANCE)

    def actions_of(self, states: np.ndarray) -> list[Action]:
        """Group single-factor segments into actions; zero-length moves are dropped."""
        moved = self.moved_factors(states)
        counts = moved.sum(axis=1)
        if np.any(counts > 1):
            raise ValueError(f"segment {int(np.argmax(counts > 1))} moves several factors; isolate the path first")
        segments = np.flatnonzero(counts)
        groups: list[tuple[int, list[np.ndarray]]] = []
        for segment, f in zip(segments.tolist(), moved[segments].argmax(axis=1).tolist(), strict=True):
            value = states[segment + 1, self.columns[f]]
            if groups and groups[-1][0] == f:
                groups[-1][1].append(value)
            else:
                groups.append((f, [value]))
        return [(f, tuple(values)) for f, values in groups]

    def replay(self, actions: Sequence[Action]) -> np.ndarray:
        current = np.array(self.problem.start, dtype=float)
        rows = [current]
        for f, waypoints in actions:
            columns = self.columns[f]
            for values in waypoints:
                current = current.copy()
                current[columns] = values
                rows.append(current)
        return np.array(rows)

    # -- checks ------------------------------------------------------------
    def _segments_valid(self, states: np.ndarray) -> bool:
        # Segment by segment: most candidates collide early, and the check stops there.
        self.validations += 1
        if type(self.model) is CollisionModel:  # the same checks in the same order, in one compiled call
            return self._motions_free(np.ascontiguousarray(states, dtype=np.float64))
        check = self.model.check_motion
        return all(check(a, b, self.steps) for a, b in zip(states[:-1], states[1:], strict=True))

    def _motions_free(self, states: np.ndarray) -> bool:
        """Whether every motion of ``states`` is free, each motion's verdict kept: a candidate repeats most
        of the current path's motions (everything after a collapsed action, after a merge), the skip and
        merge operators try the same rejected motions round after round, and a motion's check depends on
        its two states alone. The motions not judged before are checked in one compiled call that skips
        the samples where every pair is proven apart (:meth:`CollisionModel.motion_ends`: the verdicts of
        :meth:`CollisionModel.check_motion`); a motion found colliding before ends the check there."""
        width = states.shape[1] * states.itemsize
        raw = states.tobytes()
        keys = [raw[i * width:(i + 2) * width] for i in range(len(states) - 1)]
        free, colliding = self._free, self._colliding
        end = next((i for i, key in enumerate(keys) if key in colliding), len(keys))
        unknown = [i for i in range(end) if keys[i] not in free]
        if unknown:
            rows = np.array(unknown, dtype=np.int64)
            hits = self.model.motion_ends(states[rows], states[rows + 1], self.steps, False)[1] >= 0
            verdicts = hits.tolist()
            for i, hit in zip(unknown, verdicts, strict=True):
                (colliding if hit else free).add(keys[i])
            if True in verdicts:
                return False
        return end == len(keys)

    def _accept(self, candidate: list[Action], changed_from: int = 0) -> list[Action] | None:
        """The normalized candidate if it is valid and reaches the goal, else None.

        Actions before index ``changed_from`` are those of the current (valid)
        path, so their segments are not checked again."""
        states = self.replay(candidate)
        first = sum(len(waypoints) for _, waypoints in candidate[:changed_from])
        if not in_goal(self.problem, states[-1]) or not self._segments_valid(states[first:]):
            return None
        return self.actions_of(states)

    # -- operators ---------------------------------------------------------
    def _tail(self, actions: list[Action]) -> list[Action] | None:
        last = max((i for i, (f, _) in enumerate(actions) if f in self.goal_factors), default=-1)
        if last < 0 or last == len(actions) - 1:
            return None
        return self._accept(actions[: last + 1], last + 1)

    def _collapse(self, actions: list[Action]) -> list[Action] | None:
        changed = False
        for i, (f, waypoints) in enumerate(actions):
            if len(waypoints) < 2:
                continue
            candidate = [*actions[:i], (f, (waypoints[-1],)), *actions[i + 1:]]
            accepted = self._accept(candidate, i)
            if accepted is not None and len(accepted) <= len(actions):
                actions, changed = accepted, True
        return actions if changed else None

    def _merge(self, actions: list[Action]) -> list[Action] | None:
        for i, (f, first) in enumerate(actions):
            j = next((k for k in range(i + 1, len(actions)) if actions[k][0] == f), None)
            if j is None:
                continue
            merged = (f, (*first, *actions[j][1]))
            between = actions[i + 1: j]
            for candidate in ([*actions[:i], merged, *between, *actions[j + 1:]],
                              [*actions[:i], *between, merged, *actions[j + 1:]]):
                accepted = self._accept(candidate, i)
                if accepted is not None and len(accepted) < len(actions):
                    return accepted
        return None

    def _skip(self, actions: list[Action]) -> list[Action] | None:
        for i in range(len(actions)):
            accepted = self._accept([*actions[:i], *actions[i + 1:]], i)
            if accepted is not None and len(accepted) < len(actions):
                return accepted
        return None

    def run(self, path: np.ndarray, expired: Callable[[], bool] = lambda: False) -> np.ndarray:
        """The defragmented path (the input when it cannot be isolated into single-factor moves).

        ``expired`` is asked between operators; once it says True the best path so far is returned."""
        path = np.asarray(path, dtype=float)
        actions = self.isolate(path)
        if actions is None:
            return path
        for _ in range(self.max_rounds):
            improved = False
            for operator in (self._tail, self._collapse, self._merge, self._skip):
                if expired():
                    return self.replay(actions)
                better = operator(actions)
                if better is not None:
                    actions, improved = better, True
            if not improved:
                break
        return self.replay(actions)


def defragment_certificate(chain: KinematicChain, goal: Goal, certificate: Sequence[Sequence[float]],
                           resolution: float = DEFAULT_RESOLUTION) -> tuple[tuple[float, ...], ...]:
    """A certificate (chain joint order) with fewer actions: defragmented with motions checked at
    ``resolution``, kept only when it passes the certificate check (at fine resolution); else
    defragmented again with motions checked at fine resolution, kept likewise; else the input.
    Deterministic: no clock, only the defragmenter's bounded rounds."""
    problem = problem_for_chain(chain, goal)
    order = problem.model.joint_order
    columns = [chain.joint_order.index(name) for name in order]
    path = np.asarray(certificate, dtype=float)[:, columns]
    factors = problem_factors(problem)
    # A move collapsed or merged with its motion checked every 2 cm can clip a wall between samples
    # (Move N Times n = 3: about 2 % of certificates kept their raw 10-23 actions); checked every 2 mm
    # such a move is refused, and the second pass costs about 0.01 CPU s where it runs.
    for step in (resolution,) if resolution <= FINE_RESOLUTION else (resolution, FINE_RESOLUTION):
        defragmenter = Defragmenter(problem, factors, problem.model.motion_steps(step))
        clean = chain_path(problem, defragmenter.run(path))
        if not verify_certificate(chain, clean, goal):
            return clean
    return tuple(map(tuple, certificate))
