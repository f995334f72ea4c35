"""Parts of the Simple Slider, Grid World and Lockbox Random puzzles: names, handles, footprints.

Handles follow the prototype (a shaft on top of the body plus a yellow knob);
they are physical, so they carry collision geometry too. The knob's geometry
is named ``"knob"`` because the manipulation stage grasps there.

Footprints are the floor areas an object covers over its whole joint range
(its start pose plus everything it sweeps). Generators that place objects on
a plane use them to keep unrelated objects from interacting at all, so that
the only dependencies in a puzzle are the intended ones.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..chain import GRAY, GREEN, RED, RGBA, YELLOW, Geometry, Role
from ..geometry import Box, Cylinder, Pose

SHAFT_SIZE = (0.2, 0.2, 0.5)
"""Full extent of a box handle shaft standing on top of a body (prototype: 0.2 x 0.2 x h, h = 0.5)."""
SHAFT_RADIUS = 0.1
"""Radius of a cylindrical handle shaft (the prototype's disc handle)."""
KNOB_SIZE = (0.05, 0.05, 0.2)
"""Full extent of the yellow knob on top of a shaft, where a gripper takes hold."""
MAX_OBJECTS = 100
"""Object names carry two digits (``obj_00`` .. ``obj_99``)."""
OVERLAP_TOLERANCE = 1e-6
"""Metres two footprints may interpenetrate and still count as merely touching."""


def object_name(index: int) -> str:
    """``obj_00`` is the target; later objects are numbered in the order the Maker adds them."""
    if not 0 <= index < MAX_OBJECTS:
        raise ValueError(f"object index {index} is out of range 0..{MAX_OBJECTS - 1}")
    return f"obj_{index:02d}"


def movable_role(index: int) -> Role:
    return Role.TARGET if index == 0 else Role.BLOCKER


def role_color(role: Role) -> RGBA:
    return {Role.TARGET: GREEN, Role.BLOCKER: RED}.get(role, GRAY)


def box_handle(x: float, y: float, top: float, color: RGBA) -> tuple[Geometry, Geometry]:
    """A box shaft standing on the body top ``top`` (link frame z) at (x, y), plus the knob."""
    shaft = Geometry(Box(SHAFT_SIZE), Pose((x, y, top + SHAFT_SIZE[2] / 2)), color, "handle_shaft")
    return shaft, _knob(x, y, top + SHAFT_SIZE[2])


def cylinder_handle(x: float, y: float, top: float, color: RGBA) -> tuple[Geometry, Geometry]:
    """A cylindrical shaft standing on the body top ``top`` at (x, y), plus the knob."""
    shaft = Geometry(Cylinder(SHAFT_RADIUS, SHAFT_SIZE[2]), Pose((x, y, top + SHAFT_SIZE[2] / 2)), color,
                     "handle_shaft")
    return shaft, _knob(x, y, top + SHAFT_SIZE[2])


def _knob(x: float, y: float, bottom: float) -> Geometry:
    return Geometry(Box(KNOB_SIZE), Pose((x, y, bottom + KNOB_SIZE[2] / 2)), YELLOW, "knob")


def hinge(radius: float, body_height: float) -> Geometry:
    """The visual hinge pin through a revolute body's axis (visual only: it has no collision)."""
    return Geometry(Cylinder(radius, body_height + 0.1), Pose(), GRAY, "hinge")


def unit(degrees: float) -> tuple[int, int]:
    """The direction of an axis-aligned angle (0: +x, 90: +y, 180: -x, 270: -y)."""
    quarters = degrees / 90.0
    if abs(quarters - round(quarters)) > 1e-9:
        raise ValueError(f"angle {degrees} is not a multiple of 90 degrees")
    return ((1, 0), (0, 1), (-1, 0), (0, -1))[round(quarters) % 4]


# -- footprints ----------------------------------------------------------------
@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle on the floor: [x_low, x_high] x [y_low, y_high]."""

    x_low: float
    y_low: float
    x_high: float
    y_high: float

    @staticmethod
    def along(start: tuple[float, float], direction: tuple[int, int], back: float, front: float,
              half_width: float) -> Rect:
        """The rectangle from ``start - back*direction`` to ``start + front*direction``,
        ``half_width`` to either side; ``direction`` is an axis-aligned unit vector."""
        (x, y), (dx, dy) = start, direction
        xs = (x - back * dx, x + front * dx)
        ys = (y - back * dy, y + front * dy)
        if dx == 0:
            xs = (x - half_width, x + half_width)
        if dy == 0:
            ys = (y - half_width, y + half_width)
        return Rect(min(xs), min(ys), max(xs), max(ys))


@dataclass(frozen=True)
class Circle:
    """A disc on the floor (what a revolute disc sweeps)."""

    x: float
    y: float
    radius: float


Footprint = Rect | Circle


def overlaps(a: Footprint, b: Footprint, tolerance: float = OVERLAP_TOLERANCE) -> bool:
    """True when two footprints interpenetrate by more than ``tolerance`` (touching is fine)."""
    if isinstance(a, Circle) and isinstance(b, Circle):
        return math.hypot(a.x - b.x, a.y - b.y) < a.radius + b.radius - tolerance
    if isinstance(a, Circle):
        a, b = b, a
    if isinstance(b, Circle):
        assert isinstance(a, Rect)
        # Penetration of a circle into a rectangle: radius minus the distance to the nearest point.
        nx = min(max(b.x, a.x_low), a.x_high)
        ny = min(max(b.y, a.y_low), a.y_high)
        inside = a.x_low < b.x < a.x_high and a.y_low < b.y < a.y_high
        return inside or math.hypot(b.x - nx, b.y - ny) < b.radius - tolerance
    return (min(a.x_high, b.x_high) - max(a.x_low, b.x_low) > tolerance
            and min(a.y_high, b.y_high) - max(a.y_low, b.y_low) > tolerance)
