"""Puzzle objects: the generators' vocabulary, turned into a chain by :func:`build_chain`.

A generator thinks in objects ("a slider here, a door there"); the chain
model is derived from the list of objects, never edited by hand. Every object
stands on the floor and moves in the plane: prismatic joints slide along a
horizontal local axis, revolute joints turn about the vertical axis through
the object's frame, SE(2) objects translate in x and y and turn about z.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from enum import StrEnum

from .chain import Geometry, Joint, JointType, KinematicChain, Link, Role
from .geometry import Pose, Vec3

BASE_LINK = "base_link"


class Motion(StrEnum):
    """How an object may move relative to the world."""

    FIXED = "fixed"
    PRISMATIC = "prismatic"
    REVOLUTE = "revolute"
    SE2 = "se2"  # x, y, yaw
    R2 = "r2"  # x, y (yaw fixed)

    @property
    def joint_suffixes(self) -> tuple[str, ...]:
        return {
            Motion.FIXED: (),
            Motion.PRISMATIC: ("",),
            Motion.REVOLUTE: ("",),
            Motion.SE2: ("_x", "_y", "_yaw"),
            Motion.R2: ("_x", "_y"),
        }[self]


@dataclass(frozen=True)
class PuzzleObject:
    """One rigid object of a puzzle and how it may move.

    ``pose`` is the object's creation pose (its joint frame) in the world;
    the state value 0 of every joint is that pose. ``limits`` holds one
    (lower, upper) pair per joint, in the order of ``motion.joint_suffixes``.
    For a prismatic object ``axis`` is the sliding direction in the object
    frame; revolute objects turn about the frame's z axis.
    """

    name: str
    motion: Motion
    pose: Pose
    visuals: tuple[Geometry, ...] = ()
    collisions: tuple[Geometry, ...] = ()
    role: Role = Role.BLOCKER
    limits: tuple[tuple[float, float], ...] = ()
    axis: Vec3 = (1.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if not self.pose.is_planar:
            raise ValueError(f"object {self.name!r}: pose must be planar, got rpy={self.pose.rpy}")
        expected = len(self.motion.joint_suffixes)
        if len(self.limits) != expected:
            raise ValueError(
                f"object {self.name!r}: {self.motion.value} motion needs {expected} limit pairs, "
                f"got {len(self.limits)}"
            )
        for lower, upper in self.limits:
            if not lower <= upper:
                raise ValueError(f"object {self.name!r}: bad limits ({lower}, {upper})")
        if self.motion is Motion.PRISMATIC and abs(self.axis[2]) > 1e-12:
            raise ValueError(f"object {self.name!r}: prismatic axis must be horizontal, got {self.axis}")

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(self.name + s for s in self.motion.joint_suffixes)

    @property
    def is_movable(self) -> bool:
        return self.motion is not Motion.FIXED

    def fixed(self) -> PuzzleObject:
        """The same object with its joints locked at the creation pose."""
        return replace(self, motion=Motion.FIXED, limits=())


def _unit(v: Vec3) -> Vec3:
    n = math.sqrt(sum(a * a for a in v))
    return (v[0] / n, v[1] / n, v[2] / n)


def object_links_and_joints(obj: PuzzleObject, parent: str = BASE_LINK) -> tuple[list[Link], list[Joint]]:
    """Links and joints for one object; its body link is named ``obj.name``."""
    body = Link(obj.name, obj.visuals, obj.collisions, obj.role, obj.name)
    x, y, z = obj.pose.xyz
    yaw = obj.pose.yaw
    if obj.motion is Motion.FIXED:
        return [body], [Joint(obj.name, JointType.FIXED, parent, obj.name, obj.pose)]
    if obj.motion in (Motion.PRISMATIC, Motion.REVOLUTE):
        (lower, upper), = obj.limits
        joint_type = JointType.PRISMATIC if obj.motion is Motion.PRISMATIC else JointType.REVOLUTE
        axis = _unit(obj.axis) if obj.motion is Motion.PRISMATIC else (0.0, 0.0, 1.0)
        return [body], [Joint(obj.name, joint_type, parent, obj.name, obj.pose, axis, lower, upper)]
    # SE(2) / R(2): prismatic x -> prismatic y -> (revolute yaw | fixed) -> body.
    helper_x = Link(obj.name + "_base_x", role=Role.HELPER, object_name=obj.name, mass=0.01)
    helper_y = Link(obj.name + "_base_y", role=Role.HELPER, object_name=obj.name, mass=0.01)
    limits = obj.limits
    joints = [
        Joint(obj.name + "_x", JointType.PRISMATIC, parent, helper_x.name, Pose.planar(x, y, z),
              (1.0, 0.0, 0.0), *limits[0]),
        Joint(obj.name + "_y", JointType.PRISMATIC, helper_x.name, helper_y.name, Pose(),
              (0.0, 1.0, 0.0), *limits[1]),
    ]
    if obj.motion is Motion.SE2:
        joints.append(Joint(obj.name + "_yaw", JointType.REVOLUTE, helper_y.name, obj.name,
                            Pose.planar(0, 0, 0, yaw), (0.0, 0.0, 1.0), *limits[2]))
    else:
        joints.append(Joint(obj.name + "_body", JointType.FIXED, helper_y.name, obj.name,
                            Pose.planar(0, 0, 0, yaw)))
    return [helper_x, helper_y, body], joints


_CHAINS: dict[tuple, tuple[tuple[PuzzleObject, ...], KinematicChain]] = {}
_CHAINS_KEPT = 16


def build_chain(objects: Sequence[PuzzleObject], name: str = "puzzle",
                extra_links: Sequence[Link] = (), extra_joints: Sequence[Joint] = ()) -> KinematicChain:
    """The kinematic chain of a list of objects, all attached to ``base_link``.

    The last few chains of objects alone are kept by the objects' identities (objects and chains are
    immutable; the objects are kept with their chain, so no other object gets their ids while it is
    kept): a puzzle's last objects are asked for again by its certificate's clean-up and dependency
    graph, and one chain object lets the caches kept by chain identity (collision models) answer."""
    if extra_links or extra_joints:
        return _built_chain(objects, name, extra_links, extra_joints)
    objects = tuple(objects)
    key = (name, *map(id, objects))
    found = _CHAINS.get(key)
    if found is None or not all(a is b for a, b in zip(found[0], objects, strict=True)):
        if len(_CHAINS) >= _CHAINS_KEPT:
            del _CHAINS[next(iter(_CHAINS))]
        found = _CHAINS[key] = (objects, _built_chain(objects, name, (), ()))
    return found[1]


def _built_chain(objects: Sequence[PuzzleObject], name: str, extra_links: Sequence[Link],
                 extra_joints: Sequence[Joint]) -> KinematicChain:
    links: list[Link] = [Link(BASE_LINK, role=Role.BASE, mass=0.0)]
    joints: list[Joint] = []
    for obj in objects:
        obj_links, obj_joints = object_links_and_joints(obj)
        links += obj_links
        joints += obj_joints
    return KinematicChain(tuple(links) + tuple(extra_links), tuple(joints) + tuple(extra_joints),
                          BASE_LINK, name)
