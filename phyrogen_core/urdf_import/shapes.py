"""A URDF shape, placed anywhere in an object's frame, as PhyRoGen's vertical prisms.

Exact where the shape is one: a box or cylinder standing on any face (its
pose may turn it by quarter turns about x or y), an extruded mesh. Anything
else becomes the prism over its outline's convex hull (a tilted box, a
sphere, a 3D mesh), which covers the shape; the returned note says so.
"""

from __future__ import annotations

import math

import numpy as np

from ..chain import Geometry, rotation_to_rpy
from ..geometry import Box, ConvexPrism, Cylinder, Pose
from .footprint import convex_hull, footprint
from .urdf_model import ShapeSpec

VERTICAL = 1e-9
"""How far from 1 the z component of a unit axis may be and the axis still count as vertical."""
CIRCLE_SIDES = 32
"""Sides of the polygon that stands for a circle in a hull (circumscribed: it covers the circle)."""


def planar_geometries(spec: ShapeSpec, transform: np.ndarray, where: str) -> tuple[list[Geometry], str]:
    """``spec`` placed by ``transform`` (4x4: the shape's frame in the object frame) as geometries
    with planar poses, and a note ('' when exact)."""
    rotation, centre = transform[:3, :3], transform[:3, 3]
    if spec.kind == "box":
        vertical = [k for k in range(3) if abs(abs(rotation[2, k]) - 1.0) < VERTICAL]
        if vertical:
            k = vertical[0]
            i, j = (a for a in range(3) if a != k)
            yaw = math.atan2(rotation[1, i], rotation[0, i])
            # Local axes i and j lie in the plane; j is i turned by +-90 degrees, and a box is symmetric.
            box = Box((spec.size[i], spec.size[j], spec.size[k]))
            return [_geometry(spec, box, centre, yaw)], ""
        x, y, z = (s / 2 for s in spec.size)
        corners = np.array([(a, b, c) for a in (-x, x) for b in (-y, y) for c in (-z, z)])
        return _hull(spec, corners @ rotation.T + centre, f"{where}: a tilted box")
    if spec.kind == "cylinder":
        radius, length = spec.size
        if abs(abs(rotation[2, 2]) - 1.0) < VERTICAL:
            return [_geometry(spec, Cylinder(radius, length), centre, 0.0)], ""
        return _hull(spec, _circles(radius, (-length / 2, length / 2)) @ rotation.T + centre,
                     f"{where}: a cylinder whose axis is not vertical")
    if spec.kind == "sphere":
        (radius,) = spec.size
        note = f"{where}: a sphere becomes the vertical cylinder around it (radius {radius:g}, length {2 * radius:g})"
        return [_geometry(spec, Cylinder(radius, 2 * radius), centre, 0.0)], note
    assert spec.triangles is not None
    triangles = spec.triangles @ rotation.T + centre
    shape = footprint(triangles)
    middle = (shape.z_low + shape.z_high) / 2
    prism = ConvexPrism(shape.pieces, shape.z_high - shape.z_low)
    geometry = Geometry(prism, Pose((0.0, 0.0, middle)), spec.color, spec.name)
    if shape.exact:
        return [geometry], ""
    return [geometry], (f"mesh {spec.mesh} is no extruded outline ({shape.why}); it becomes the prism over its "
                        "outline's convex hull, which covers it (conservative)")


def _geometry(spec: ShapeSpec, shape, centre: np.ndarray, yaw: float) -> Geometry:
    x, y, z = (float(v) + 0.0 for v in centre)
    return Geometry(shape, Pose((x, y, z), (0.0, 0.0, yaw + 0.0)), spec.color, spec.name)


def _circles(radius: float, heights: tuple[float, float]) -> np.ndarray:
    reach = radius / math.cos(math.pi / CIRCLE_SIDES)
    angles = 2 * math.pi * np.arange(CIRCLE_SIDES) / CIRCLE_SIDES
    ring = np.stack([reach * np.cos(angles), reach * np.sin(angles)], axis=1)
    return np.concatenate([np.column_stack([ring, np.full(len(ring), h)]) for h in heights])


def _hull(spec: ShapeSpec, points: np.ndarray, what: str) -> tuple[list[Geometry], str]:
    low, high = float(points[:, 2].min()), float(points[:, 2].max())
    prism = ConvexPrism((convex_hull(points[:, :2], 1e-9),), high - low)
    return ([Geometry(prism, Pose((0.0, 0.0, (low + high) / 2)), spec.color, spec.name)],
            f"{what} becomes the prism over its outline's convex hull, which covers it (conservative)")


def planar_frame(transform: np.ndarray) -> np.ndarray:
    """The planar frame (x, y, z and yaw only) at the origin of ``transform``, facing its x axis
    (its y axis where x is vertical)."""
    pose = rotation_to_rpy(transform)
    out = np.eye(4)
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    out[:2, :2] = [[c, -s], [s, c]]
    out[:3, 3] = transform[:3, 3]
    return out


def frame_yaw(transform: np.ndarray) -> float:
    """The yaw of a planar frame."""
    return math.atan2(transform[1, 0], transform[0, 0])
