"""Components of the Continuous Space, Move N Times and Rooms puzzles: names, handles, walls.

Every puzzle follows the same conventions, kept here so that the generators
agree: movable objects are ``obj_00`` (the target), ``obj_01``, ... in the
order they are added; fixed scenery is ``fixed_00_wall``, ``fixed_01_pillar``,
...; every movable object carries a handle (a shaft on top of its body and a
yellow knob named ``knob``, where the manipulation stage grasps it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from ..chain import BLACK, GRAY, GREEN, RED, RGBA, YELLOW, Geometry, Role
from ..geometry import Box, Cylinder, Pose, Vec3
from ..objects import Motion, PuzzleObject

MAX_NAMED = 100
"""Object names carry a two-digit index, so a puzzle holds at most 100 of each kind."""

HANDLE_SHAFT_WIDTH = 0.2
HANDLE_SHAFT_HEIGHT = 0.5
KNOB_SIZE: Vec3 = (0.05, 0.05, 0.2)
KNOB_NAME = "knob"

MOVABLE_PREFIX = "obj_"
FIXED_PREFIX = "fixed_"


def movable_name(index: int) -> str:
    """``obj_00`` is the target; blockers follow in the order they are added."""
    _check_index(index)
    return f"{MOVABLE_PREFIX}{index:02d}"


def fixed_name(index: int, kind: str) -> str:
    """``fixed_<index>_<kind>``, e.g. ``fixed_03_wall``."""
    _check_index(index)
    return f"{FIXED_PREFIX}{index:02d}_{kind}"


def _check_index(index: int) -> None:
    if not 0 <= index < MAX_NAMED:
        raise ValueError(f"object index {index} does not fit a two-digit name (valid: 0..{MAX_NAMED - 1})")


def count_movable(objects: Sequence[PuzzleObject]) -> int:
    return sum(1 for o in objects if o.name.startswith(MOVABLE_PREFIX))


def count_fixed(objects: Sequence[PuzzleObject]) -> int:
    return sum(1 for o in objects if o.name.startswith(FIXED_PREFIX))


def role_and_color(index: int) -> tuple[Role, RGBA]:
    """The target (index 0) is green, every other movable object a red blocker."""
    return (Role.TARGET, GREEN) if index == 0 else (Role.BLOCKER, RED)


AT_FRAME = Pose()


def box(size: Vec3, color: RGBA, origin: Pose = AT_FRAME, name: str = "body") -> Geometry:
    return Geometry(Box(size), origin, color, name)


def handle(top: float, at: tuple[float, float] = (0.0, 0.0), color: RGBA = GRAY,
           shaft_width: float = HANDLE_SHAFT_WIDTH,
           shaft_height: float = HANDLE_SHAFT_HEIGHT) -> tuple[Geometry, Geometry]:
    """A shaft standing on the body top (``top`` = its height above the link frame) at
    ``at`` in the link frame, and a yellow knob on the shaft.

    Both are physical (the caller puts them in visuals and collisions): a
    handle that passed through other objects could not be grasped.
    """
    x, y = at
    shaft = Geometry(Box((shaft_width, shaft_width, shaft_height)),
                     Pose((x, y, top + shaft_height / 2)), color, "handle_shaft")
    knob = Geometry(Box(KNOB_SIZE), Pose((x, y, top + shaft_height + KNOB_SIZE[2] / 2)), YELLOW, KNOB_NAME)
    return shaft, knob


def hinge(radius: float, length: float) -> Geometry:
    """A visual-only hinge pin on the joint axis (callers keep it out of collisions)."""
    return Geometry(Cylinder(radius, length), Pose(), GRAY, "hinge")


def fixed_box(name: str, x: float, y: float, size: Vec3, color: RGBA = GRAY,
              yaw: float = 0.0) -> PuzzleObject:
    """A box of scenery standing on the floor, centred at (x, y)."""
    body = box(size, color)
    return PuzzleObject(name, Motion.FIXED, Pose.planar(x, y, size[2] / 2, yaw), (body,), (body,),
                        Role.STATIC, ())


def wall(index: int, x: float, y: float, size: Vec3) -> PuzzleObject:
    return fixed_box(fixed_name(index, "wall"), x, y, size, GRAY)


def pillar(index: int, x: float, y: float, size: Vec3) -> PuzzleObject:
    return fixed_box(fixed_name(index, "pillar"), x, y, size, BLACK)


@dataclass(frozen=True)
class Footprint:
    """A rectangle on the floor: centre, yaw and half extents along its own axes."""

    x: float
    y: float
    yaw: float
    half_x: float
    half_y: float

    def corners(self) -> tuple[tuple[float, float], ...]:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return tuple(
            (self.x + c * u * self.half_x - s * v * self.half_y,
             self.y + s * u * self.half_x + c * v * self.half_y)
            for u, v in ((-1, -1), (1, -1), (1, 1), (-1, 1))
        )


def footprints_overlap(a: Footprint, b: Footprint, tolerance: float = 1e-6) -> bool:
    """Whether two rectangles interpenetrate by more than ``tolerance`` (touching is no overlap).

    Separating-axis test over the four edge normals; the same rule as the
    solver's collision model, so a start pose accepted here is valid there.
    """
    corners_a, corners_b = a.corners(), b.corners()
    for yaw in (a.yaw, b.yaw):
        for nx, ny in ((math.cos(yaw), math.sin(yaw)), (-math.sin(yaw), math.cos(yaw))):
            pa = [nx * x + ny * y for x, y in corners_a]
            pb = [nx * x + ny * y for x, y in corners_b]
            if min(max(pa), max(pb)) - max(min(pa), min(pb)) <= tolerance:
                return False
    return True
