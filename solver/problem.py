"""The planning problem over a puzzle chain, and what reads, densifies or checks its paths.

Everything here works without OMPL (collision model and numpy only), so the
Blender add-on, the manipulation stage and the certificate check can use it
without loading the planners; OMPL's side of validation is
:mod:`solver.validation`.

Paths of a :class:`Problem` list states in the problem's joint order
(``problem.model.joint_order``: the chain's active joints without the locked
ones); :func:`chain_path` expands them to the chain's full joint order, the
order of certificates and puzzle files.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from phyrogen_core.chain import KinematicChain
from phyrogen_core.objects import PuzzleObject, build_chain
from phyrogen_core.puzzle import Goal

from .collision import CollisionModel

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


def problem_for_chain(chain: KinematicChain, goal: Goal) -> Problem:
    """The planning problem of a puzzle chain (built by a generator or read from a folder) with its goal.

    Joints whose limits have zero width are locked at their start value (0
    clipped into the limits). Raises :class:`UnreachableGoalError` when a goal
    joint is not an active joint of the chain, or is locked away from its goal value.
    """
    locked = [j for j in chain.active_joints if j.upper - j.lower < LOCKED_WIDTH]
    locked_names = {j.name for j in locked}
    for name, value in goal.values.items():
        if name not in chain.joint_order:
            raise UnreachableGoalError(f"goal joint {name!r} is not an active joint of chain {chain.name!r}; "
                                       f"valid: {list(chain.joint_order)}")
        locked_at = chain.joint(name).lower
        if name in locked_names and abs(locked_at - value) > goal.tolerance:
            raise UnreachableGoalError(f"goal joint {name!r} of chain {chain.name!r} is locked at {locked_at} "
                                       f"(limits of zero width), away from its goal value {value}")
    model = CollisionModel(chain, {j.name: max(min(0.0, j.upper), j.lower) for j in locked})
    order = model.joint_order
    lower = np.array([chain.joint(n).lower for n in order])
    upper = np.array([chain.joint(n).upper for n in order])
    start = np.clip(np.zeros(len(order)), lower, upper)
    columns = {order.index(n): float(v) for n, v in goal.values.items() if n in order}
    return Problem(model, start, columns, lower, upper, goal.tolerance)


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
    column = {n: i for i, n in enumerate(model.joint_order)}
    return tuple(
        tuple(float(state[column[n]]) if n in column else float(model.locked[n]) for n in model.chain.joint_order)
        for state in path
    )


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
    points, _ = segment_points(states, steps)
    return bool(model.check_prepared(points).all())


def verify_certificate(chain: KinematicChain, path, goal: Goal, resolution: float = FINE_RESOLUTION) -> list[str]:
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
