"""The custom properties a puzzle scene carries: Phobos's keys and our own.

Phobos (dfki-ric/phobos, 2.x) reads ``phobostype``, ``link/name``,
``model/name``, ``joint/*``, ``geometry/type``, ``mass`` and ``inertia``;
with them a user who has Phobos can export our scene to URDF. Blender stores
transforms and mesh vertices in single precision, so the exact (double)
values are kept beside them under ``phyrogen/*``: the reader uses an exact
value while the scene still agrees with it, and the scene's value once a user
has edited the object. No bpy here, so all of this is testable without Blender.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from phyrogen_core.chain import Joint, JointType, Link, pose_matrix, rotation_to_rpy
from phyrogen_core.export.urdf import link_inertia
from phyrogen_core.geometry import Pose

PHOBOSTYPES = (
    "undefined", "link", "inertial", "visual", "collision", "sensor", "controller", "approxsphere",
    "light", "entity", "frame", "interface", "submodel", "annotation", "submechanism",
)
"""Phobos 2.x's ``phobostype`` enum items, in Phobos's order (the enum stores indices)."""

# Phobos keys.
LINK_NAME = "link/name"
MODEL_NAME = "model/name"
JOINT_NAME = "joint/name"
JOINT_TYPE = "joint/type"
JOINT_AXIS = "joint/axis"
JOINT_LOWER = "joint/limits/lower"
JOINT_UPPER = "joint/limits/upper"
JOINT_EFFORT = "joint/limits/effort"
JOINT_VELOCITY = "joint/limits/velocity"
GEOMETRY_TYPE = "geometry/type"
MASS = "mass"
INERTIA = "inertia"

# Our keys: exact values and what URDF cannot say.
ROLE = "phyrogen/role"
OBJECT = "phyrogen/object"
LINK_INDEX = "phyrogen/link_index"
JOINT_INDEX = "phyrogen/joint_index"
ORIGIN = "phyrogen/origin"  # xyz + rpy of a joint origin or a geometry origin, exact
SIZE = "phyrogen/size"  # box size, or (radius, length), or (height,) of a prism piece
PIECE = "phyrogen/piece"  # a prism piece's outline, x0 y0 x1 y1 ...
GEOMETRY_INDEX = "phyrogen/index"
PIECE_INDEX = "phyrogen/piece_index"
GEOMETRY_NAME = "phyrogen/name"
RGBA = "phyrogen/rgba"
METADATA = "phyrogen/metadata"  # puzzle.json text, on the puzzle's collection
PUZZLE_NAME = "phyrogen/puzzle"  # on the puzzle's collection
URDF_DIGEST = "phyrogen/urdf_sha256"  # of the URDF the puzzle.json was written for, on the collection

SNAP_TOLERANCE = 1e-4
"""Largest difference (metres, radians, colour units) still read as single-precision
rounding of the exact value; anything larger is a user's edit."""


def joint_properties(joint: Joint) -> dict[str, Any]:
    """Phobos's joint annotations, stored on the joint's child link."""
    return {
        JOINT_NAME: joint.name,
        JOINT_TYPE: joint.type.value,
        JOINT_AXIS: [float(a) for a in joint.axis],
        JOINT_LOWER: float(joint.lower),
        JOINT_UPPER: float(joint.upper),
        JOINT_EFFORT: float(joint.effort),
        JOINT_VELOCITY: float(joint.velocity),
        ORIGIN: pose_values(joint.origin),
    }


def joint_from_properties(props: Mapping[str, Any], default_name: str, parent: str, child: str,
                          origin: Pose) -> Joint:
    """The joint described by a link's annotations; raises ValueError naming a bad value."""
    kind = str(props.get(JOINT_TYPE, "fixed"))
    valid = [t.value for t in JointType]
    if kind not in valid:
        raise ValueError(f"link {child!r}: {JOINT_TYPE} {kind!r} is not supported; valid: {valid}")
    joint_type = JointType(kind)
    axis = tuple(float(a) for a in props.get(JOINT_AXIS, (0.0, 0.0, 1.0)))
    if len(axis) != 3:
        raise ValueError(f"link {child!r}: {JOINT_AXIS} must be 3 numbers, got {list(axis)}")
    norm = math.sqrt(sum(a * a for a in axis))
    if norm == 0:
        raise ValueError(f"link {child!r}: {JOINT_AXIS} must not be zero")
    if abs(norm - 1.0) > 1e-9:
        axis = tuple(a / norm for a in axis)
    return Joint(
        str(props.get(JOINT_NAME, default_name)), joint_type, parent, child, origin, axis,  # type: ignore[arg-type]
        float(props.get(JOINT_LOWER, 0.0)), float(props.get(JOINT_UPPER, 0.0)),
        float(props.get(JOINT_EFFORT, 100.0)), float(props.get(JOINT_VELOCITY, 1.0)),
    )


def pose_values(pose: Pose) -> list[float]:
    return [float(v) for v in (*pose.xyz, *pose.rpy)]


def pose_from_values(values: Sequence[float]) -> Pose:
    if len(values) != 6:
        raise ValueError(f"a pose needs 6 numbers (x y z roll pitch yaw), got {list(values)}")
    xyz = tuple(float(v) for v in values[:3])
    rpy = tuple(float(v) for v in values[3:])
    return Pose(xyz, rpy)  # type: ignore[arg-type]


def snapped_pose(scene_matrix: np.ndarray, stored: Sequence[float] | None) -> Pose:
    """The exact stored pose while the scene's (single-precision) matrix still matches it."""
    if stored is not None and len(stored) == 6:
        exact = pose_from_values(stored)
        if np.max(np.abs(pose_matrix(exact) - scene_matrix)) <= SNAP_TOLERANCE:
            return exact
    pose = rotation_to_rpy(scene_matrix)
    return Pose(tuple(_clean(v) for v in pose.xyz), tuple(_clean(v) for v in pose.rpy))  # type: ignore[arg-type]


def snapped_values(scene_values: Sequence[float], stored: Sequence[float] | None) -> tuple[float, ...]:
    """The exact stored values while the scene's values still match them, else the scene's."""
    scene = tuple(float(v) for v in scene_values)
    if stored is not None and len(stored) == len(scene):
        exact = tuple(float(v) for v in stored)
        if all(abs(a - b) <= SNAP_TOLERANCE * max(1.0, abs(a)) for a, b in zip(exact, scene, strict=True)):
            return exact
    return tuple(_clean(v) for v in scene)


def _clean(value: float) -> float:
    """Single-precision noise rounded away (7 significant digits), -0.0 made 0.0."""
    return float(f"{value:.7g}") + 0.0


def inertial_values(link: Link) -> tuple[list[float], list[float]]:
    """Centre and ``[ixx, ixy, ixz, iyy, iyz, izz]``: the core's URDF inertial (:func:`link_inertia`)."""
    centre, (ixx, iyy, izz) = link_inertia(link)
    return [float(c) for c in centre], [ixx, 0.0, 0.0, iyy, 0.0, izz]
