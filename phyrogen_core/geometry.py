"""Shapes and poses: the geometric vocabulary of the chain model.

Every shape is expressed in its own frame with its axis of extrusion along +z,
so that a shape placed with a pose whose roll and pitch are zero is a vertical
prism. The collision checker relies on that (see ``solver.collision.model``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

Vec3 = tuple[float, float, float]
Point2 = tuple[float, float]


@dataclass(frozen=True)
class Pose:
    """A rigid transform: translation ``xyz`` and URDF roll-pitch-yaw ``rpy``."""

    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)

    @staticmethod
    def planar(x: float, y: float, z: float = 0.0, yaw: float = 0.0) -> Pose:
        return Pose((float(x), float(y), float(z)), (0.0, 0.0, float(yaw)))

    @property
    def is_planar(self) -> bool:
        """True when the pose only rotates about z (roll = pitch = 0)."""
        return abs(self.rpy[0]) < 1e-12 and abs(self.rpy[1]) < 1e-12

    @property
    def yaw(self) -> float:
        return self.rpy[2]


@dataclass(frozen=True)
class Box:
    """An axis-aligned box centred on its frame; ``size`` is the full extent."""

    size: Vec3

    def __post_init__(self) -> None:
        if len(self.size) != 3 or min(self.size) <= 0:
            raise ValueError(f"Box size must be three positive numbers, got {self.size!r}")


@dataclass(frozen=True)
class Cylinder:
    """A cylinder centred on its frame, axis along local z."""

    radius: float
    length: float

    def __post_init__(self) -> None:
        if self.radius <= 0 or self.length <= 0:
            raise ValueError(
                f"Cylinder radius and length must be positive, got {self.radius!r}, {self.length!r}"
            )


@dataclass(frozen=True)
class ConvexPrism:
    """A prism of height ``height`` (centred on z = 0) over a union of convex polygons.

    Non-convex outlines such as the slot disc are given as several convex
    ``pieces``; each piece is a counter-clockwise list of (x, y) vertices.
    """

    pieces: tuple[tuple[Point2, ...], ...]
    height: float

    def __post_init__(self) -> None:
        if self.height <= 0 or not self.pieces:
            raise ValueError("ConvexPrism needs a positive height and at least one piece")
        for piece in self.pieces:
            if len(piece) < 3:
                raise ValueError(f"ConvexPrism piece needs at least 3 vertices, got {piece!r}")
            if _signed_area(piece) <= 0:
                raise ValueError("ConvexPrism pieces must be counter-clockwise polygons")


Shape = Box | Cylinder | ConvexPrism


def _signed_area(polygon: tuple[Point2, ...]) -> float:
    return 0.5 * sum(
        x0 * y1 - x1 * y0
        for (x0, y0), (x1, y1) in zip(polygon, polygon[1:] + polygon[:1], strict=True)
    )


def regular_polygon(radius: float, sides: int, start_angle: float = 0.0) -> tuple[Point2, ...]:
    """Counter-clockwise vertices of a regular polygon with circumradius ``radius``."""
    return tuple(
        (
            radius * math.cos(start_angle + 2 * math.pi * k / sides),
            radius * math.sin(start_angle + 2 * math.pi * k / sides),
        )
        for k in range(sides)
    )


def slot_disc(radius: float, height: float, sides: int = 32) -> ConvexPrism:
    """A regular ``sides``-gon prism with a slot from the centre to the +x rim.

    The slot covers x in [0, r], |y| <= r/4 (prototype dimensions). The outline
    is split into three convex pieces: the x <= 0 half and the two x >= 0 parts
    above and below the slot.
    """
    ring = regular_polygon(radius, sides)
    half_width = radius / 4

    def clip_poly(poly: tuple[Point2, ...], keep) -> tuple[Point2, ...]:
        # Sutherland-Hodgman against one half-plane given as (a, b, c): a*x + b*y <= c.
        a, b, c = keep
        out: list[Point2] = []
        for p, q in zip(poly, poly[1:] + poly[:1], strict=True):
            dp, dq = a * p[0] + b * p[1] - c, a * q[0] + b * q[1] - c
            if dp <= 0:
                out.append(p)
            if dp * dq < 0:
                t = dp / (dp - dq)
                out.append((p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])))
        return tuple(out)

    back = clip_poly(ring, (1.0, 0.0, 0.0))  # x <= 0
    front = clip_poly(ring, (-1.0, 0.0, 0.0))  # x >= 0
    front_top = clip_poly(front, (0.0, -1.0, -half_width))  # y >= r/4
    front_bottom = clip_poly(front, (0.0, 1.0, -half_width))  # y <= -r/4
    pieces = tuple(_dedupe(p) for p in (back, front_top, front_bottom))
    return ConvexPrism(pieces=pieces, height=height)


def _dedupe(poly: tuple[Point2, ...]) -> tuple[Point2, ...]:
    out: list[Point2] = []
    for p in poly:
        p = (round(p[0], 12) + 0.0, round(p[1], 12) + 0.0)
        if not out or abs(out[-1][0] - p[0]) > 1e-9 or abs(out[-1][1] - p[1]) > 1e-9:
            out.append(p)
    if len(out) > 1 and abs(out[0][0] - out[-1][0]) < 1e-9 and abs(out[0][1] - out[-1][1]) < 1e-9:
        out.pop()
    return tuple(out)
