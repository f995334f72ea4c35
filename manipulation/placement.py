"""Where the puzzle stands in the robot's world, and how large.

The generators build puzzles in their own units (a Rooms puzzle is 16 m
across, a Simple Slider 1.6 m); a mobile iiwa reaches about 0.6 m past the
edge of its base. Each puzzle is therefore scaled uniformly so that
everything it occupies along the solution fits in a square of
``max_extent`` metres, and centred on the world origin. The puzzle's own
URDF is not touched: the scene loads a scaled copy derived from the chain.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from phyrogen_core.chain import Geometry, Joint, JointType, KinematicChain, joint_motion, pose_matrix
from phyrogen_core.export.urdf import collision_bounds
from phyrogen_core.geometry import Box, ConvexPrism, Cylinder, Pose, Shape

DEFAULT_MAX_EXTENT = 1.1
"""Metres: the side of the square the scaled puzzle (over its whole solution) fits in."""


@dataclass(frozen=True)
class Placement:
    """world = (offset_x, offset_y, 0) + scale * puzzle coordinates (no rotation)."""

    scale: float
    offset: tuple[float, float]

    def __post_init__(self) -> None:
        if not self.scale > 0:
            raise ValueError(f"placement scale must be positive, got {self.scale!r}")


def planar_bounds(chain: KinematicChain, states: Sequence[Sequence[float]]) -> tuple[np.ndarray, np.ndarray]:
    """Floor-plane (x, y) bounds of every collision shape of ``chain`` over ``states``."""
    lows, highs = [], []
    for state in states:
        world = chain.link_transforms(state)
        for link in chain.links:
            if not link.collisions:
                continue
            low, high = collision_bounds(link)
            corners = np.array([[x, y, z, 1.0] for x in (low[0], high[0]) for y in (low[1], high[1])
                                for z in (low[2], high[2])])
            points = corners @ world[link.name].T
            lows.append(points[:, :2].min(axis=0))
            highs.append(points[:, :2].max(axis=0))
    if not lows:
        raise ValueError(f"chain {chain.name!r} has no collision shapes to place")
    return np.min(lows, axis=0), np.max(highs, axis=0)


def fit_placement(chain: KinematicChain, states: Sequence[Sequence[float]],
                  max_extent: float = DEFAULT_MAX_EXTENT) -> Placement:
    """Scale (never enlarging) so the puzzle fits ``max_extent``, centred on the origin."""
    if not max_extent > 0:
        raise ValueError(f"max_extent must be positive metres, got {max_extent!r}")
    low, high = planar_bounds(chain, states)
    extent = float(np.max(high - low))
    scale = min(1.0, max_extent / extent)
    centre = (low + high) / 2
    return Placement(scale, (float(-scale * centre[0]), float(-scale * centre[1])))


def scale_chain(chain: KinematicChain, scale: float) -> KinematicChain:
    """The same chain, ``scale`` times as large: shapes, origins and prismatic limits."""
    links = tuple(replace(link, visuals=tuple(_scale_geometry(g, scale) for g in link.visuals),
                          collisions=tuple(_scale_geometry(g, scale) for g in link.collisions))
                  for link in chain.links)
    joints = tuple(_scale_joint(j, scale) for j in chain.joints)
    return KinematicChain(links, joints, chain.root, chain.name)


def joint_value_scale(chain: KinematicChain, scale: float) -> np.ndarray:
    """Per joint (joint order): how a puzzle joint value becomes a scaled-scene value."""
    return np.array([scale if j.type is JointType.PRISMATIC else 1.0 for j in chain.active_joints])


def _scale_pose(pose: Pose, scale: float) -> Pose:
    x, y, z = pose.xyz
    return Pose((x * scale, y * scale, z * scale), pose.rpy)


def _scale_shape(shape: Shape, scale: float) -> Shape:
    if isinstance(shape, Box):
        return Box(tuple(v * scale for v in shape.size))  # type: ignore[arg-type]
    if isinstance(shape, Cylinder):
        return Cylinder(shape.radius * scale, shape.length * scale)
    if isinstance(shape, ConvexPrism):
        pieces = tuple(tuple((x * scale, y * scale) for x, y in piece) for piece in shape.pieces)
        return ConvexPrism(pieces, shape.height * scale)
    raise TypeError(f"unsupported shape {type(shape).__name__}; valid: Box, Cylinder, ConvexPrism")


def _scale_geometry(geometry: Geometry, scale: float) -> Geometry:
    return replace(geometry, shape=_scale_shape(geometry.shape, scale), origin=_scale_pose(geometry.origin, scale))


def _scale_joint(joint: Joint, scale: float) -> Joint:
    scaled = replace(joint, origin=_scale_pose(joint.origin, scale))
    if joint.type is JointType.PRISMATIC:
        scaled = replace(scaled, lower=joint.lower * scale, upper=joint.upper * scale)
    return scaled


def link_point_world(chain: KinematicChain, link: str, point: np.ndarray, state: Sequence[float]) -> np.ndarray:
    """A point given in a link's frame, in the chain's frame at ``state``."""
    m = chain.link_transforms(state)[link]
    return m[:3, :3] @ point + m[:3, 3]



def link_pose(chain: KinematicChain, link: str, state: Sequence[float]) -> np.ndarray:
    """The world 4x4 transform of one link at ``state`` (walks only that link's joints)."""
    values = dict(zip(chain.joint_order, state, strict=True))
    m = np.eye(4)
    name = link
    while name != chain.root:
        joint = chain.parent_joint(name)
        assert joint is not None
        q = values.get(joint.name, 0.0) if joint.is_active else 0.0
        m = pose_matrix(joint.origin) @ joint_motion(joint, q) @ m
        name = joint.parent
    return m
