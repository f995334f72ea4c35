"""The planning problem over a puzzle chain, and what reads, densifies or checks its paths.

Everything here works without OMPL (collision model and numpy only), so the
Blender add-on, the manipulation stage and the certificate check can use it
without loading the planners; OMPL's side of validation is
:mod:`solver.validation.validator`.

Paths of a :class:`Problem` list states in the problem's joint order
(``problem.model.joint_order``: the chain's active joints without the locked
ones); :func:`chain_path` expands them to the chain's full joint order, the
order of certificates and puzzle files.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from phyrogen_core.chain import KinematicChain
from phyrogen_core.objects import PuzzleObject, build_chain
from phyrogen_core.puzzle import Goal
from solver.collision.model import DEFAULT_TOLERANCE, CollisionModel

DEFAULT_RESOLUTION = 0.02
"""Metres any collision point may move between two checked states while validating."""
FINE_RESOLUTION = 0.002
"""Metres between checked states when a certificate is re-checked."""
GOAL_SLACK = 1e-12
"""Added to the goal tolerance in every goal test, as :meth:`phyrogen_core.puzzle.Goal.is_reached` does."""
LOCKED_WIDTH = 1e-12
"""A joint whose limits are closer than this is locked: OMPL rejects empty bounds."""

Path = tuple[tuple[float, ...], ...]


class UnreachableGoalError(ValueError):
    """The chain cannot reach its goal at all: a goal joint is missing or locked away from its goal."""


@dataclass(frozen=True)
class Problem:
    """A planning problem over the free joints of a chain (locked joints held at their value)."""

    model: CollisionModel
    start: np.ndarray
    goal_columns: dict[int, float]
    lower: np.ndarray
    upper: np.ndarray
    tolerance: float


def problem_for_chain(chain: KinematicChain, goal: Goal, *, fixed: Sequence[str] = (), shrink: float = 0.0) -> Problem:
    """The planning problem of a puzzle chain (built by a generator or read from a folder) with its goal.

    Joints whose limits have zero width are locked at their start value (0
    clipped into the limits), and so are the joints of the objects named in
    ``fixed`` (the Maker's FixJoint). ``shrink`` (metres) shrinks every
    collision shape: two shapes then collide only where they overlap by more
    than ``2 * shrink`` (see :func:`shrunk_tolerance`). Raises
    :class:`UnreachableGoalError` when a goal joint is not an active joint of
    the chain, or is locked away from its goal value.
    """
    movable, owner = _owners(chain)
    fixed_set = set(fixed)
    unknown = fixed_set - set(movable)
    if unknown:
        raise ValueError(f"cannot fix {sorted(unknown)}: not movable objects of chain {chain.name!r}; "
                         f"valid: {list(movable)}")
    if not (math.isfinite(shrink) and shrink >= 0):
        raise ValueError(f"shrink must be a finite number of metres >= 0, got {shrink!r}")
    fixed_joints = {j for j in chain.joint_order if owner[j] in fixed_set}
    locked = [j for j in chain.active_joints if j.upper - j.lower < LOCKED_WIDTH or j.name in fixed_joints]
    locked_names = {j.name for j in locked}
    for name, value in goal.values.items():
        if name not in chain.joint_order:
            raise UnreachableGoalError(f"goal joint {name!r} is not an active joint of chain {chain.name!r}; "
                                       f"valid: {list(chain.joint_order)}")
        joint = chain.joint(name)
        locked_at = max(min(0.0, joint.upper), joint.lower)
        if name in locked_names and abs(locked_at - value) > goal.tolerance:
            raise UnreachableGoalError(f"goal joint {name!r} of chain {chain.name!r} is locked at {locked_at} "
                                       f"(fixed, or limits of zero width), away from its goal value {value}")
    model = collision_model(chain, {j.name: max(min(0.0, j.upper), j.lower) for j in locked},
                            shrunk_tolerance(shrink))
    order = model.joint_order
    lower = np.array([chain.joint(n).lower for n in order])
    upper = np.array([chain.joint(n).upper for n in order])
    start = np.clip(np.zeros(len(order)), lower, upper)
    columns = {order.index(n): float(v) for n, v in goal.values.items() if n in order}
    return Problem(model, start, columns, lower, upper, goal.tolerance)


_OWNERS: dict[int, tuple[KinematicChain, tuple[str, ...], dict[str, str]]] = {}


def _owners(chain: KinematicChain) -> tuple[tuple[str, ...], dict[str, str]]:
    """``chain.object_names`` and each active joint's object, the last few kept by the chain's identity (a
    chain is immutable, and kept with them): the judges ask for many problems of one chain."""
    found = _OWNERS.get(id(chain))
    if found is None or found[0] is not chain:
        if len(_OWNERS) >= _MODELS_KEPT:
            del _OWNERS[next(iter(_OWNERS))]
        found = _OWNERS[id(chain)] = (chain, chain.object_names,
                                      {j: chain.object_of_joint(j) for j in chain.joint_order})
    return found[1], found[2]


_MODELS: dict[tuple, tuple[KinematicChain, CollisionModel]] = {}
_MODELS_KEPT = 16


def collision_model(chain: KinematicChain, locked: dict[str, float] | None = None,
                    tolerance: float = DEFAULT_TOLERANCE) -> CollisionModel:
    """``CollisionModel(chain, locked, tolerance)``, the last few kept: one puzzle asks for the same
    model several times (each judge of a candidate, the validator's solve and its certificate check).
    Kept by the chain's identity (a chain is immutable, and kept alive with its model) and the exact
    locked values and tolerance, so a kept model is the one that would be built."""
    key = (id(chain), tuple((name, float(value).hex()) for name, value in (locked or {}).items()),
           float(tolerance).hex())
    found = _MODELS.get(key)
    if found is not None and found[0] is chain:
        return found[1]
    model = CollisionModel(chain, locked, tolerance)
    if len(_MODELS) >= _MODELS_KEPT:
        del _MODELS[next(iter(_MODELS))]
    _MODELS[key] = (chain, model)
    return model


def shrunk_tolerance(shrink: float) -> float:
    """The collision model's penetration tolerance that stands for shrinking every shape by
    ``shrink`` metres: two shapes shrunk by ``s`` each overlap only where the originals
    overlap by more than ``2 s`` along every separating axis. (At a corner the true
    shrunk outline is rounded, so this is slightly more permissive than shrinking: a
    superfluous-object test only gets stricter by it.)"""
    return max(DEFAULT_TOLERANCE, 2.0 * shrink)


def problem_for_objects(objects: Sequence[PuzzleObject], goal: Goal) -> Problem | None:
    """:func:`problem_for_chain` of the objects' chain; None when the target cannot reach its
    goal at all (the Maker's FixJoint of the target)."""
    try:
        return problem_for_chain(build_chain(objects), goal)
    except UnreachableGoalError:
        return None


def problem_factors(problem: Problem) -> dict[str, tuple[int, ...]]:
    """Object name -> columns of the problem's state it moves (one factor per object).

    The rule of :attr:`phyrogen_core.chain.KinematicChain.factors`, over the
    problem's joint order (locked joints left out) instead of the chain's.
    """
    chain = problem.model.chain
    out: dict[str, list[int]] = {}
    for index, name in enumerate(problem.model.joint_order):
        out.setdefault(chain.object_of_joint(name), []).append(index)
    return {k: tuple(v) for k, v in out.items()}


def chain_path(problem: Problem, path: Sequence[Sequence[float]]) -> Path:
    """``path`` (problem joint order) expanded to every active joint of the chain (locked ones at their value)."""
    model = problem.model
    # One numpy copy instead of a Python float() per state and joint: the same float64 values.
    states = np.asarray(path if isinstance(path, np.ndarray | Sequence) else list(path), dtype=np.float64)
    if len(states) == 0:
        return ()
    column = {n: i for i, n in enumerate(model.joint_order)}
    order = model.chain.joint_order
    free = [k for k, n in enumerate(order) if n in column]
    out = np.empty((len(states), len(order)))
    out[:, free] = states[:, [column[order[k]] for k in free]]
    for k, n in enumerate(order):
        if n not in column:
            out[:, k] = float(model.locked[n])
    if not order:
        return ((),) * len(out)
    return tuple(zip(*out.T.tolist(), strict=True))  # one list per joint, zipped: no list per state


def goal_distance(problem: Problem, state) -> float:
    """The largest distance of a goal joint of ``state`` (problem joint order) from its goal value."""
    return max((abs(state[i] - v) for i, v in problem.goal_columns.items()), default=0.0)


def in_goal(problem: Problem, state) -> bool:
    """Whether ``state`` (problem joint order) is in the goal region: the rule of
    :meth:`phyrogen_core.puzzle.Goal.is_reached`."""
    return goal_distance(problem, state) <= problem.tolerance + GOAL_SLACK


# -- densifying and checking paths ---------------------------------------------------
def segment_points(states: np.ndarray, steps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Interpolated states along every segment of ``states`` (excluding the first state) and,
    per point, the index of its segment; no joint moves more than ``steps`` between points."""
    states = np.asarray(states, dtype=float)
    diffs = states[1:] - states[:-1]
    counts = np.maximum(1, np.ceil(np.max(np.abs(diffs) / steps, axis=1))).astype(np.int64)
    segment = np.repeat(np.arange(len(diffs)), counts)
    offsets = np.cumsum(counts) - counts
    t = (np.arange(len(segment)) - offsets[segment] + 1) / counts[segment]
    points = np.ascontiguousarray(states[segment] + diffs[segment] * t[:, None])
    return points, segment


def densify(path, steps: np.ndarray) -> np.ndarray:
    """All states along a piecewise-linear path, its first state included, with at most
    ``steps[j]`` of joint ``j`` between consecutive rows."""
    states = np.asarray(path, dtype=float)
    return np.concatenate([states[:1], segment_points(states, steps)[0]])


def path_is_valid(model: CollisionModel, states: np.ndarray, steps: np.ndarray) -> bool:
    """Whether every segment of ``states`` is collision-free at ``steps`` (the first state is assumed valid)."""
    if len(states) < 2:
        return True
    if type(model) is CollisionModel:  # the same points, those where every pair is proven apart skipped
        return model.path_free(np.ascontiguousarray(states, dtype=np.float64), steps)
    points, _ = segment_points(states, steps)
    return bool(model.check_prepared(points).all())


def verify_certificate(chain: KinematicChain, path, goal: Goal, resolution: float = FINE_RESOLUTION, *,
                       start=None) -> list[str]:
    """Problems with a certificate (empty when it is valid): its states are finite, it starts at
    the start state, stays within the limits and collision-free at ``resolution``, and ends in a
    sensible goal (:func:`~phyrogen_core.export.reader.goal_problems`).

    ``start`` (joint order) defaults to the chain's start state
    (:func:`~phyrogen_core.export.reader.start_state`: every joint at 0
    clipped into its limits, where the planners start and which a puzzle
    folder's ``puzzle.json`` must state). A path that leaves the limits, or
    would need more than :data:`MAX_CHECKED_STATES` states at ``resolution``,
    is reported without a collision check.
    """
    from phyrogen_core.export.reader import goal_problems, start_state

    order = chain.joint_order
    try:
        states = np.asarray(path, dtype=float)
    except (TypeError, ValueError) as exc:
        return [f"certificate is not a list of states of numbers: {exc}"]
    if states.ndim != 2 or len(states) < 1:
        return ["certificate is empty" if states.size == 0 else
                f"certificate must be a list of states, got an array of shape {states.shape}"]
    if states.shape[1] != len(order):
        return [f"certificate states have {states.shape[1]} values, chain has {len(order)} joints"]
    bad_rows = np.flatnonzero(~np.isfinite(states).all(axis=1))
    if bad_rows.size:
        return [f"certificate state {bad_rows[0]} holds a value that is not a finite number"]
    expected = np.asarray(start_state(chain) if start is None else start, dtype=float)
    if expected.shape != (len(order),) or not np.isfinite(expected).all():
        return [f"the start state must be {len(order)} finite numbers, got {start!r}"]
    problems = [f"goal: {problem}" for problem in goal_problems(goal, chain, expected)]
    off = np.abs(states[0] - expected)
    if off.max() > 1e-9:
        column = int(np.argmax(off))
        problems.append(f"certificate does not begin at the start state (joint {order[column]!r} is at "
                        f"{states[0, column]!r}, the start state has {expected[column]!r})")
    lower, upper = chain.lower_limits, chain.upper_limits
    outside = (states < lower - 1e-9) | (states > upper + 1e-9)
    if outside.any():
        row, column = (int(i[0]) for i in np.nonzero(outside))
        problems.append(f"certificate leaves the joint limits (state {row}, joint {order[column]!r} at "
                        f"{states[row, column]!r}, limits [{lower[column]!r}, {upper[column]!r}]); "
                        "not checked for collisions")
    else:
        problems += _collision_problems(collision_model(chain), states, resolution)
    if not goal.is_reached(chain.state_dict(states[-1])):
        problems.append("certificate does not end in the goal")
    return problems


MAX_CHECKED_STATES = 2_000_000
"""The most states :func:`verify_certificate` checks along one certificate (the paper's puzzles
need about 10 000 at :data:`FINE_RESOLUTION`); a longer check is refused, not attempted."""


def _collision_problems(model: CollisionModel, states: np.ndarray, resolution: float) -> list[str]:
    """The collision problem of a certificate within its limits, checked at ``resolution`` in chunks."""
    steps = model.motion_steps(resolution)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ratios = np.nan_to_num(np.abs(np.diff(states, axis=0)) / steps, nan=0.0, posinf=np.inf)
    counts = np.maximum(1.0, np.ceil(ratios.max(axis=1))) if len(states) > 1 else np.zeros(0)
    total = 1.0 + float(counts.sum())  # the first state, then each segment's points
    if not total <= MAX_CHECKED_STATES:
        return [f"certificate needs {total:.3g} checked states at resolution {resolution} m, more than the "
                f"{MAX_CHECKED_STATES} a check may take; not checked for collisions"]
    bad = 0 if model.is_valid(states[0]) else 1
    states = np.ascontiguousarray(states)
    if not model.path_free(states, steps):  # then counted point by point, none held in memory
        bad += model.path_collisions(states, steps)
    if bad:
        return [f"certificate collides at {bad} of {int(total)} checked states"]
    return []


def dependency_graph(objects: Sequence[PuzzleObject], certificate, resolution: float = DEFAULT_RESOLUTION,
                     shrink: float = 0.0) -> tuple[tuple[str, str], ...]:
    """(blocker, blocked) pairs read off a certificate.

    Object B blocks object A when A's motion along the certificate would run
    into B had B stayed at its start pose: B had to get out of A's way. With
    ``shrink`` every shape is shrunk first (:func:`shrunk_tolerance`), so a
    pair that only grazes by less than the interlock margin is no edge.
    """
    return chain_dependency_graph(build_chain(objects), certificate, resolution, shrunk_tolerance(shrink))


def chain_dependency_graph(chain: KinematicChain, certificate, resolution: float = DEFAULT_RESOLUTION,
                           tolerance: float = DEFAULT_TOLERANCE) -> tuple[tuple[str, str], ...]:
    """:func:`dependency_graph` for a chain (one read from a puzzle folder has no generator
    objects), with the collision model's ``tolerance``."""
    model = collision_model(chain, tolerance=tolerance)
    states = densify(certificate, model.motion_steps(resolution))
    edges: set[tuple[str, str]] = set()
    for blocker, columns in chain.factors.items():
        frozen = states.copy()
        frozen[:, list(columns)] = 0.0
        edges |= {(blocker, a if b == blocker else b) for a, b in model.colliding_objects_with(frozen, blocker)}
    return tuple(sorted(edges))
