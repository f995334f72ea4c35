"""Where the puzzle stands in the robot's world, and how large: a physical scale per generator.

The generators build puzzles in their own units, and the same 5 x 5 x 20 cm
knob sits on a 1 m Lockbox disc and on a 0.2 m Simple Slider. The scene
scales each puzzle uniformly by its generator's physical scale (the
registry's ``scene_scale``; the reasoning is in
``docs/manipulation/README.md#physical-scale``),
stands it on the floor and centres it on the world origin; the mobile base
drives around it, so a larger puzzle means longer drives, not a smaller
puzzle. The puzzle's own URDF is not touched: the scene loads a scaled copy
derived from the chain.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from phyrogen_core.chain import Geometry, Joint, JointType, KinematicChain, joint_motion, pose_matrix
from phyrogen_core.export.urdf import collision_bounds
from phyrogen_core.geometry import Box, ConvexPrism, Cylinder, Pose, Shape
from phyrogen_core.registry import all_generators


def physical_scale(generator: str) -> float:
    """The generator's physical scale (its registry entry's ``scene_scale``); 1 for puzzles of
    other origins (imported URDFs are in metres already)."""
    generators = all_generators()
    return generators[generator].scene_scale if generator in generators else 1.0


@dataclass(frozen=True)
class Placement:
    """world = (offset_x, offset_y, 0) + scale * puzzle coordinates (no rotation)."""

    scale: float
    offset: tuple[float, float]
    half_extent: tuple[float, float] = (0.0, 0.0)
    """Metres: half the size (x, y) of the floor area the scaled puzzle covers over its solution,
    which is centred on the origin."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.scale) and self.scale > 0):
            raise ValueError(f"the scene scale must be a positive number, got {self.scale!r}")


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


def centred_placement(chain: KinematicChain, states: Sequence[Sequence[float]], scale: float) -> Placement:
    """``scale`` times the puzzle, the floor area it covers over ``states`` centred on the origin."""
    low, high = planar_bounds(chain, states)
    centre = (low + high) / 2
    half = scale * (high - low) / 2
    return Placement(scale, (float(-scale * centre[0]), float(-scale * centre[1])), (float(half[0]), float(half[1])))


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
