"""Inverse kinematics at a grasp pose, respecting joint limits, and choosing among solutions.

PyBullet's IK ignores joint limits unless it is given the null-space
arguments (limits, ranges, rest pose); it is run from several base rest
poses around the grasp point, a few iterations each, and every answer is
re-checked: pose error, distance from the limits, collisions with the puzzle
and the robot itself, and manipulability now and at the next object poses
(so that a grasp is not chosen where the robot would be singular a moment
later).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .linalg import damped_least_squares, manipulability
from .robot import ARM_REST
from .scene import World
from .transforms import matrix, quaternion, rotation_error, tool_down

POSITION_TOLERANCE = 1e-3
ORIENTATION_TOLERANCE = 1e-2
REFINE_STEPS = 8
GRASP_CLEARANCE = 0.008
"""Metres a grasp configuration (and its look-ahead) keeps from the puzzle: more than the
follower's stopping clearance, so a fresh grasp is not stopped at once."""
EXCLUDE_RADIUS = 0.15
"""Metres: a regrasp puts the base at least this far from where the failed grasp had it."""
LIMIT_MARGIN = 0.08
"""Radians an IK answer must keep from every arm joint limit."""


Future = tuple[np.ndarray, np.ndarray]
"""A tool pose (4x4) the grasp must reach next, with the puzzle's joint values there."""


@dataclass(frozen=True)
class IkSettings:
    nearest: float = 0.3
    farthest: float = 0.85
    """Metres from the grasp point to the base centre: the range searched in each direction."""
    step: float = 0.05
    per_direction: int = 3
    """Base positions tried per direction: the nearest where the base clears the puzzle, then
    every ``spacing`` metres farther out."""
    spacing: float = 0.1
    directions: int = 24
    """Candidate directions (evenly spaced) from the grasp point to the base."""
    iterations: int = 4
    good_enough: float = 0.06
    """Arm manipulability at which the search stops early (candidates nearest the robot come first)."""


@dataclass(frozen=True)
class IkSolution:
    q: np.ndarray
    score: float
    """The smallest arm manipulability over the grasp pose and the look-ahead poses."""


def solve_at(world: World, pose: np.ndarray, seed: Sequence[float], iterations: int = 4,
             fixed_base: bool = False) -> np.ndarray | None:
    """Joint values putting the tool at ``pose`` (4x4), starting from ``seed``; None if IK misses.

    ``fixed_base``: the base joints keep the seed's values (as while following).
    Leaves the planning world's robot at the answer.
    """
    lower, upper = world.lower.copy(), world.upper.copy()
    if fixed_base:  # a sliver of range: PyBullet's IK hangs on a zero one
        base = np.asarray(seed, dtype=float)[:3]
        lower[:3], upper[:3] = base - 1e-6, base + 1e-6
    position, orientation = list(pose[:3, 3]), quaternion(pose)
    world.set_robot(seed)
    q = np.asarray(seed, dtype=float)
    for _ in range(iterations):
        q = world.inverse_kinematics(position, orientation, lower, upper, seed)
        q = np.clip(q, lower, upper)
        world.set_robot(q)
        position_error, angle_error = _pose_error(world, pose)
        if position_error < POSITION_TOLERANCE / 4 and angle_error < ORIENTATION_TOLERANCE / 4:
            break
    weights = np.ones(len(q))
    if fixed_base:
        weights[:3] = 1e6
    q = _refine(world, pose, q, lower, upper, weights)
    position_error, angle_error = _pose_error(world, pose)
    if position_error > POSITION_TOLERANCE or angle_error > ORIENTATION_TOLERANCE:
        return None
    return q


def _refine(world: World, pose: np.ndarray, q: np.ndarray, lower: np.ndarray, upper: np.ndarray,
            weights: np.ndarray) -> np.ndarray:
    """Damped Newton steps on the full pose error, from an answer of PyBullet's IK.

    With null-space arguments PyBullet's IK keeps pulling toward the rest
    pose and stalls about a millimetre short; a few steps without that pull
    close the gap (or show that the pose is out of reach)."""
    for _ in range(REFINE_STEPS):
        actual = matrix(*world.tool_pose())
        error = np.concatenate([pose[:3, 3] - actual[:3, 3], rotation_error(pose[:3, :3], actual[:3, :3])])
        if np.linalg.norm(error[:3]) < POSITION_TOLERANCE / 20 and \
                np.linalg.norm(error[3:]) < ORIENTATION_TOLERANCE / 20:
            break
        step = damped_least_squares(np.ascontiguousarray(world.jacobian(q)), weights, 0.01, error)
        q = np.clip(q + step, lower, upper)
        world.set_robot(q)
    return q


def _pose_error(world: World, pose: np.ndarray) -> tuple[float, float]:
    actual = matrix(*world.tool_pose())
    return (float(np.linalg.norm(actual[:3, 3] - pose[:3, 3])),
            float(np.linalg.norm(rotation_error(pose[:3, :3], actual[:3, :3]))))


def arm_quality(world: World, q: np.ndarray) -> float:
    """Arm manipulability at ``q``, or 0 when an arm joint is within LIMIT_MARGIN of a limit."""
    arm = world.arm_columns
    if np.any(q[arm] < world.lower[arm] + LIMIT_MARGIN) or np.any(q[arm] > world.upper[arm] - LIMIT_MARGIN):
        return 0.0
    return manipulability(np.ascontiguousarray(world.jacobian(q)[:, arm]))


def base_positions(world: World, point: np.ndarray, settings: IkSettings,
                   clearance: float) -> list[tuple[float, np.ndarray]]:
    """(direction, base x, y) around ``point`` where the base, facing it, clears the puzzle: in each
    direction the nearest such position and a few farther out (the nearest reach deepest into a
    puzzle; the farther leave the arm room)."""
    out = []
    for k in range(settings.directions):
        angle = 2 * math.pi * k / settings.directions
        direction = np.array([math.cos(angle), math.sin(angle)])
        heading = math.remainder(angle + math.pi, 2 * math.pi)
        taken = 0
        last = -math.inf
        for distance in np.arange(settings.nearest, settings.farthest + 1e-9, settings.step):
            base = point[:2] + distance * direction
            if distance - last < settings.spacing - 1e-9 or not world.base_clear(base, heading, clearance):
                continue
            out.append((angle, base))
            last = distance
            taken += 1
            if taken == settings.per_direction:
                break
    return out


def best_grasp_configuration(world: World, point: np.ndarray,
                             lookahead: Callable[[np.ndarray], Sequence[Future]] = lambda pose: (),
                             settings: IkSettings = IkSettings(),
                             avoid: Sequence[np.ndarray] = (),
                             prefer_near: np.ndarray | None = None,
                             clearance: float = GRASP_CLEARANCE,
                             base_ok: Callable[[np.ndarray], bool] = lambda xy: True,
                             align: Callable[[float], float] = lambda yaw: yaw) -> IkSolution | None:
    """The best collision-free IK answer for a tool-down grasp at ``point`` over candidate base poses.

    ``lookahead(pose)`` gives the tool poses a grasp at ``pose`` must reach
    next, each with the puzzle state there (the object's coming positions); a
    candidate that cannot follow them by IK, clear of the puzzle, scores 0.
    ``avoid``: bases (x, y) of configurations that just failed (a grasp that stopped, a base
    the robot could not get to); candidates keep :data:`EXCLUDE_RADIUS` from them, so that a
    regrasp really changes the robot's posture.
    ``prefer_near``: the base (x, y) now; candidates closest to it come first.
    ``clearance``: metres every configuration keeps from the puzzle.
    ``base_ok(xy)``: whether the base may stand at ``xy`` (say, the floor there is reachable).
    ``align(yaw)``: the tool yaw to grasp with instead of ``yaw`` (the fingers across the handle).
    """
    candidates = [(angle, base) for angle, base in base_positions(world, point, settings, clearance)
                  if base_ok(base)]
    if prefer_near is not None:
        candidates.sort(key=lambda c: float(np.linalg.norm(c[1] - prefer_near)))
    best: IkSolution | None = None
    for angle, base in candidates:
        if best is not None and best.score >= settings.good_enough:
            break
        if any(np.linalg.norm(base - other) < EXCLUDE_RADIUS for other in avoid):
            continue
        heading = math.remainder(angle + math.pi, 2 * math.pi)  # face the grasp point
        # At the rest pose the tool's x axis points back at the base: tool yaw = heading + pi.
        pose = tool_down(point, align(heading + math.pi))
        seed = np.array([base[0], base[1], heading, *ARM_REST])
        q = solve_at(world, pose, seed, settings.iterations, fixed_base=True)
        if q is None or world.in_collision(clearance):
            continue
        score = arm_quality(world, q)
        current = q
        now = world.puzzle_state()
        for future_pose, future_puzzle in lookahead(pose):
            if score <= (best.score if best else 0.0):
                break
            world.set_puzzle(future_puzzle)
            current = solve_at(world, future_pose, current, settings.iterations, fixed_base=True)
            clear = current is not None and not world.in_collision(clearance)
            score = min(score, arm_quality(world, current)) if clear else 0.0
        world.set_puzzle(now)
        if best is None or score > best.score:
            best = IkSolution(q, score)
    return best
