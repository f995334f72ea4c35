"""The goal of an imported puzzle: from the pose of a ``goal`` link, or from given joint values.

The prototype marks the goal with a link named ``goal``, fixed to the world
where the target's body is to be (with a translucent copy of the target
below it). Which object is the target is not written anywhere; it is the
one movable object whose body can be put on that pose within its joint
limits (and is not there already). More than one such object, or none, is
an error that says how to name the target instead.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..chain import pose_matrix
from ..objects import Motion
from ..puzzle import GOAL_TOLERANCE
from .objects import ImportedObject, JointMap

POSITION_TOLERANCE = 1e-3
"""Metres (plus a millionth of the coordinates' size) the goal pose may lie off what an object can
reach: the prototype writes poses with five decimals and pi/2 as 1.5708."""
ANGLE_TOLERANCE = 1e-3
"""Radians the goal pose may be turned off what an object can reach."""


@dataclass(frozen=True)
class GoalChoice:
    target: str  # the puzzle object's name
    values: dict[str, float]  # puzzle joint name -> goal value
    source: str  # how it was found, for the report


def goal_from_pose(objects: Sequence[ImportedObject], pose: np.ndarray, target: str | None = None) -> GoalChoice:
    """The goal that puts a movable object's body on ``pose`` (4x4, world); ``target`` (an object,
    URDF link or joint name) restricts the choice to that object."""
    movable = [item for item in objects if item.obj.is_movable]
    if target is not None:
        movable = [find_object(objects, target)[0]]
    fits: list[tuple[ImportedObject, dict[str, float]]] = []
    reasons: list[str] = []
    for item in movable:
        values = _reach(item, pose)
        if isinstance(values, str):
            reasons.append(f"{item.obj.name}: {values}")
        elif all(abs(v) <= GOAL_TOLERANCE for v in values.values()):
            reasons.append(f"{item.obj.name}: it is there at the start already")
        else:
            fits.append((item, values))
    where = _show_pose(pose)
    if not fits:
        detail = "; ".join(reasons[:3]) + (f"; and {len(reasons) - 3} more" if len(reasons) > 3 else "")
        raise ValueError(f"no movable object can be put on the goal link's pose {where} within its joint limits "
                         f"({detail}); name the target and its goal with --target and --goal")
    if len(fits) > 1:
        raise ValueError(f"the goal link's pose {where} fits several objects: "
                         f"{[item.obj.name for item, _ in fits]}; name the target with --target")
    item, values = fits[0]
    return GoalChoice(item.obj.name, values, "goal link")


def goal_from_values(objects: Sequence[ImportedObject], target: str, values: Sequence[float]) -> GoalChoice:
    """The goal given as URDF joint values: one for a joint named ``target``, or one per URDF joint of
    the object ``target`` names (an object, or any URDF link of it), from the world outwards."""
    item, joint = find_object(objects, target)
    if joint is not None and len(values) > 1 and target in item.links:
        joint = None  # the prototype names a joint's child link after the joint: several values mean the object
    maps: tuple[JointMap, ...] = (joint,) if joint is not None else item.joints
    if not maps:
        raise ValueError(f"--target {target!r} names a fixed object; the target must move")
    if len(values) != len(maps):
        names = [m.urdf for m in maps]
        raise ValueError(f"--goal needs {len(maps)} value{'s' if len(maps) > 1 else ''} for --target {target!r} "
                         f"(URDF joint{'s' if len(maps) > 1 else ''} {names}), got {len(values)}")
    return GoalChoice(item.obj.name, {m.joint: m.value(v) for m, v in zip(maps, values, strict=True)},
                      "arguments")


def find_object(objects: Sequence[ImportedObject], name: str) -> tuple[ImportedObject, JointMap | None]:
    """The object ``name`` stands for (its name, a URDF link of it, or a URDF joint of it, then also
    that joint's map)."""
    for item in objects:
        for joint in item.joints:
            if name == joint.urdf:
                return item, joint
    for item in objects:
        if name == item.obj.name or name in item.links:
            return item, None
    movable = [item.obj.name for item in objects if item.obj.is_movable]
    raise ValueError(f"--target {name!r} is no link, joint or object of the URDF; movable objects: {movable}")


def _reach(item: ImportedObject, pose: np.ndarray) -> dict[str, float] | str:
    """The joint values that put ``item``'s body on ``pose``, or why there are none."""
    obj = item.obj
    want = pose @ np.linalg.inv(item.body_offset)  # where the object's frame must be
    if math.acos(min(1.0, max(-1.0, float(want[2, 2])))) > ANGLE_TOLERANCE:
        return "the goal pose is tilted against it"
    rest = pose_matrix(obj.pose)
    tolerance = POSITION_TOLERANCE + 1e-6 * float(np.abs(want[:3, 3]).max())
    if abs(want[2, 3] - rest[2, 3]) > tolerance:
        return f"it moves at height {rest[2, 3]:g}, the goal is at {want[2, 3]:g}"
    shift = want[:2, 3] - rest[:2, 3]
    turn = _wrap(math.atan2(want[1, 0], want[0, 0]) - obj.pose.yaw)
    names = obj.joint_names
    if obj.motion is Motion.PRISMATIC:
        direction = rest[:2, :2] @ np.asarray(obj.axis[:2])
        value = float(shift @ direction)
        if abs(turn) > ANGLE_TOLERANCE or np.linalg.norm(shift - value * direction) > tolerance:
            return "its slide does not pass through the goal pose"
        wanted = [value]
    elif obj.motion is Motion.REVOLUTE:
        if np.linalg.norm(shift) > tolerance:
            return "its hinge is not at the goal position"
        wanted = [turn]
    elif obj.motion is Motion.R2:
        if abs(turn) > ANGLE_TOLERANCE:
            return "it cannot turn to the goal orientation"
        wanted = [float(shift[0]), float(shift[1])]
    else:
        wanted = [float(shift[0]), float(shift[1]), turn]
    values: dict[str, float] = {}
    for name, value, (lower, upper), suffix in zip(names, wanted, obj.limits, obj.motion.joint_suffixes, strict=True):
        slack = ANGLE_TOLERANCE if suffix in ("_yaw",) or obj.motion is Motion.REVOLUTE else tolerance
        if suffix == "_yaw" or obj.motion is Motion.REVOLUTE:
            # A turn is the same turn 2 pi later: take the one within the limits closest to 0.
            turns = [value + 2 * math.pi * k for k in range(-2, 3)]
            inside = [t for t in turns if lower - slack <= t <= upper + slack]
            value = min(inside, key=abs) if inside else value
        if not lower - slack <= value <= upper + slack:
            return f"joint {name!r} would need {value:.6g}, outside its limits [{lower:g}, {upper:g}]"
        values[name] = min(max(value, lower), upper) + 0.0
    return values


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def _show_pose(pose: np.ndarray) -> str:
    x, y, z = pose[:3, 3]
    return f"(x {x:g}, y {y:g}, z {z:g}, yaw {math.atan2(pose[1, 0], pose[0, 0]):.4g})"
