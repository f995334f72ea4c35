"""The kinematic-chain model: the single source of truth for every output.

Generators produce a :class:`KinematicChain`; the collision model, the OMPL
problem, URDF/SRDF, Blender objects and the PyBullet scene are all derived
from it. The state vector of a chain is ordered by joint *name*
(:attr:`KinematicChain.joint_order`), everywhere.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from .geometry import Pose, Shape, Vec3

RGBA = tuple[float, float, float, float]

GREEN: RGBA = (0.0, 1.0, 0.0, 1.0)
RED: RGBA = (1.0, 0.0, 0.0, 1.0)
GRAY: RGBA = (0.5, 0.5, 0.5, 1.0)
BLACK: RGBA = (0.0, 0.0, 0.0, 1.0)
YELLOW: RGBA = (1.0, 1.0, 0.0, 1.0)
GOAL_GREEN: RGBA = (0.0, 1.0, 0.0, 0.25)


class Role(StrEnum):
    """What a link is in the puzzle; decides colour and how planners treat it."""

    TARGET = "target"
    BLOCKER = "blocker"
    STATIC = "static"
    GOAL_MARKER = "goal_marker"
    HELPER = "helper"  # geometry-less link of a multi-joint object (SE(2) x, y)
    BASE = "base"


class JointType(StrEnum):
    FIXED = "fixed"
    PRISMATIC = "prismatic"
    REVOLUTE = "revolute"


@dataclass(frozen=True)
class Geometry:
    """One shape placed in a link frame, with a colour (used for visuals)."""

    shape: Shape
    origin: Pose = Pose()
    color: RGBA = GRAY
    name: str = ""


@dataclass(frozen=True)
class Link:
    name: str
    visuals: tuple[Geometry, ...] = ()
    collisions: tuple[Geometry, ...] = ()
    role: Role = Role.STATIC
    # Links that move together as one puzzle object share an ``object_name``
    # (e.g. an SE(2) object's x, y helper links and its body).
    object_name: str = ""
    mass: float = 1.0


@dataclass(frozen=True)
class Joint:
    name: str
    type: JointType
    parent: str
    child: str
    origin: Pose = Pose()
    axis: Vec3 = (0.0, 0.0, 1.0)
    lower: float = 0.0
    upper: float = 0.0
    effort: float = 100.0
    velocity: float = 1.0

    def __post_init__(self) -> None:
        if self.type is not JointType.FIXED and not self.lower <= self.upper:
            raise ValueError(
                f"joint {self.name!r}: lower limit {self.lower} exceeds upper limit {self.upper}"
            )
        norm = math.sqrt(sum(a * a for a in self.axis))
        if abs(norm - 1.0) > 1e-9:
            raise ValueError(f"joint {self.name!r}: axis {self.axis} is not a unit vector")

    @property
    def is_active(self) -> bool:
        return self.type is not JointType.FIXED


@dataclass(frozen=True)
class KinematicChain:
    """Links and joints forming a tree rooted at ``root`` (``base_link``)."""

    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    root: str = "base_link"
    name: str = "puzzle"
    _index: dict = field(default=None, init=False, repr=False, compare=False)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        names = [link.name for link in self.links]
        if len(set(names)) != len(names):
            dupes = sorted({n for n in names if names.count(n) > 1})
            raise ValueError(f"duplicate link names: {dupes}")
        joint_names = [j.name for j in self.joints]
        if len(set(joint_names)) != len(joint_names):
            dupes = sorted({n for n in joint_names if joint_names.count(n) > 1})
            raise ValueError(f"duplicate joint names: {dupes}")
        if self.root not in names:
            raise ValueError(f"root link {self.root!r} is missing")
        parent_of: dict[str, Joint] = {}
        for joint in self.joints:
            for end in (joint.parent, joint.child):
                if end not in names:
                    raise ValueError(f"joint {joint.name!r} refers to unknown link {end!r}")
            if joint.child in parent_of:
                raise ValueError(f"link {joint.child!r} has two parent joints")
            parent_of[joint.child] = joint
        unreachable = set(names) - {self.root} - set(parent_of)
        if unreachable:
            raise ValueError(f"links not connected to {self.root!r}: {sorted(unreachable)}")
        object.__setattr__(
            self,
            "_index",
            {
                "link": {link.name: link for link in self.links},
                "joint": {j.name: j for j in self.joints},
                "parent_joint": parent_of,
                "topo": _topological_links(self.root, self.joints),
                # Asked for in every state conversion (the chain is immutable): sorted once.
                "order": tuple(sorted(j.name for j in self.joints if j.is_active)),
            },
        )

    # -- lookups -----------------------------------------------------------
    def link(self, name: str) -> Link:
        return self._index["link"][name]

    def joint(self, name: str) -> Joint:
        return self._index["joint"][name]

    def parent_joint(self, link_name: str) -> Joint | None:
        return self._index["parent_joint"].get(link_name)

    @property
    def links_in_tree_order(self) -> tuple[str, ...]:
        """Link names, parents before children (ties broken by name)."""
        return self._index["topo"]

    @property
    def joint_order(self) -> tuple[str, ...]:
        """Names of the active (non-fixed) joints, sorted: the state-vector order."""
        return self._index["order"]

    @property
    def active_joints(self) -> tuple[Joint, ...]:
        return tuple(self.joint(n) for n in self.joint_order)

    @property
    def lower_limits(self) -> np.ndarray:
        return np.array([j.lower for j in self.active_joints], dtype=float)

    @property
    def upper_limits(self) -> np.ndarray:
        return np.array([j.upper for j in self.active_joints], dtype=float)

    def object_of_joint(self, joint_name: str) -> str:
        return self.link(self.joint(joint_name).child).object_name

    @property
    def object_names(self) -> tuple[str, ...]:
        """Objects that own at least one active joint, in joint order."""
        seen: list[str] = []
        for name in self.joint_order:
            obj = self.object_of_joint(name)
            if obj not in seen:
                seen.append(obj)
        return tuple(seen)

    @property
    def factors(self) -> dict[str, tuple[int, ...]]:
        """Object name -> indices into the state vector of the joints it moves."""
        out: dict[str, list[int]] = {}
        for index, name in enumerate(self.joint_order):
            out.setdefault(self.object_of_joint(name), []).append(index)
        return {k: tuple(v) for k, v in out.items()}

    def state_dict(self, state: Sequence[float]) -> dict[str, float]:
        order = self.joint_order
        if len(state) != len(order):
            raise ValueError(f"state has {len(state)} values, chain has {len(order)} active joints")
        return {name: float(v) for name, v in zip(order, state, strict=True)}

    # -- kinematics --------------------------------------------------------
    def link_transforms(self, state: Sequence[float] | Mapping[str, float]) -> dict[str, np.ndarray]:
        """World 4x4 transforms of every link frame at ``state``."""
        values = state if isinstance(state, Mapping) else self.state_dict(state)
        world = {self.root: np.eye(4)}
        for link_name in self.links_in_tree_order[1:]:
            joint = self.parent_joint(link_name)
            assert joint is not None
            t = world[joint.parent] @ pose_matrix(joint.origin)
            q = float(values.get(joint.name, 0.0)) if joint.is_active else 0.0
            world[link_name] = t @ joint_motion(joint, q)
        return world


def _topological_links(root: str, joints: Sequence[Joint]) -> tuple[str, ...]:
    children: dict[str, list[str]] = {}
    for joint in joints:
        children.setdefault(joint.parent, []).append(joint.child)
    order, stack = [], [root]
    while stack:
        name = stack.pop()
        order.append(name)
        stack.extend(sorted(children.get(name, []), reverse=True))
    return tuple(order)


def rotation_matrix(rpy: Vec3) -> np.ndarray:
    """URDF convention: R = Rz(yaw) @ Ry(pitch) @ Rx(roll)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def pose_matrix(pose: Pose) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rotation_matrix(pose.rpy)
    m[:3, 3] = pose.xyz
    return m


def joint_motion(joint: Joint, q: float) -> np.ndarray:
    m = np.eye(4)
    axis = np.asarray(joint.axis, dtype=float)
    if joint.type is JointType.PRISMATIC:
        m[:3, 3] = axis * q
    elif joint.type is JointType.REVOLUTE:
        x, y, z = axis
        c, s = math.cos(q), math.sin(q)
        k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
        m[:3, :3] = np.eye(3) + s * k + (1 - c) * (k @ k)
    return m


def rotation_to_rpy(matrix: np.ndarray) -> Pose:
    """The URDF pose (xyz, rpy) of a 4x4 transform."""
    r = matrix[:3, :3]
    pitch = math.asin(max(-1.0, min(1.0, -r[2, 0])))
    if abs(math.cos(pitch)) > 1e-9:
        roll = math.atan2(r[2, 1], r[2, 2])
        yaw = math.atan2(r[1, 0], r[0, 0])
    else:  # gimbal lock: put everything into yaw
        roll = 0.0
        yaw = math.atan2(-r[0, 1], r[1, 1])
    xyz = tuple(float(v) + 0.0 for v in matrix[:3, 3])
    return Pose(xyz, (roll + 0.0, pitch + 0.0, yaw + 0.0))  # type: ignore[arg-type]
