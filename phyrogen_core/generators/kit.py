"""The generators' shared kit: names, roles and colours, handles, hinges, walls, floor areas,
grid cells and directions, transformation sets and the paper's goal.

Every puzzle follows the same conventions, kept here so that the generators
agree: movable objects are ``obj_00`` (the target, green), ``obj_01``, ...
(red blockers) in the order they are added; fixed scenery is
``fixed_00_wall``, ``fixed_01_pillar``, ...; every movable object carries a
handle (a shaft on top of its body and a yellow knob named ``knob``, where the
manipulation stage grasps it). Handles are physical, so they carry collision
geometry too; hinges are visual only.

Floor areas (:class:`Rect`, :class:`Circle`, :class:`OrientedRect`) are what
an object covers on the floor, at one pose or over its whole joint range (its
*swept area*). Generators that place objects on a plane use them to keep
unrelated objects from interacting at all, so that the only dependencies in a
puzzle are the intended ones.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from ..chain import BLACK, GRAY, GREEN, RED, RGBA, YELLOW, Geometry, Role
from ..geometry import Box, Cylinder, Pose, Vec3
from ..maker import Draft, MakerInput
from ..objects import Motion, PuzzleObject
from ..puzzle import Goal, paper_goal
from ..registry import ParameterError, parameter

# -- names, roles, colours ---------------------------------------------------------
MAX_OBJECTS = 100
"""Object names carry a two-digit index, so a puzzle holds at most 100 movable objects
(``obj_00`` .. ``obj_99``) and 100 pieces of fixed scenery."""

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
    if not 0 <= index < MAX_OBJECTS:
        raise ValueError(f"object index {index} does not fit a two-digit name (valid: 0..{MAX_OBJECTS - 1})")


def count_movable(objects: Sequence[PuzzleObject]) -> int:
    return sum(1 for o in objects if o.name.startswith(MOVABLE_PREFIX))


def count_fixed(objects: Sequence[PuzzleObject]) -> int:
    return sum(1 for o in objects if o.name.startswith(FIXED_PREFIX))


def role_and_color(index: int) -> tuple[Role, RGBA]:
    """The target (movable index 0) is green, every other movable object a red blocker."""
    return (Role.TARGET, GREEN) if index == 0 else (Role.BLOCKER, RED)


# -- parameter checks ----------------------------------------------------------------
SIZES_DOC = "docs/generators.md#feasible-sizes"
"""Where the bound every accepted size keeps (2 minutes of CPU time per puzzle) and the
measurements behind each generator's maxima are written down; refusals point there."""


def check_object_count(n_objects: int, low: int = 1, high: int = MAX_OBJECTS - 1, why: str = "") -> None:
    """Raise :class:`ParameterError` unless ``low <= n_objects <= high`` (at most ``MAX_OBJECTS - 1``);
    ``why`` says what sets ``high`` when it is not the two-digit names."""
    check_count("n_objects", n_objects, low, high, why)


def check_margin_and_count(params: object, high: int, costs: str) -> None:
    """:func:`check_interlock_margin`, then ``n_objects`` of ``params`` in 1..``high``, the refusal saying that
    generation time grows steeply with the count and what sizes near ``high`` cost (``costs``)."""
    check_interlock_margin(params)
    check_object_count(params.n_objects, high=high,
                       why=f"generation time grows steeply with the count ({costs}; {SIZES_DOC})")


def check_count(name: str, value: int, low: int, high: int, why: str = "") -> None:
    """Raise :class:`ParameterError` unless ``low <= value <= high``, one line with ``why`` appended."""
    if not low <= value <= high:
        raise ParameterError(f"{name} must lie in {low}..{high}, got {value}" + (f": {why}" if why else ""))


def seed_sized(params: object, name: str, from_seed: int, meaning: str) -> int:
    """The size the field ``name`` of ``params`` asks for: its value, or ``from_seed`` when it is 0 (the paper
    takes the size from the seed; ``meaning`` says how, e.g. "Seed + 1"). Raises :class:`ParameterError`
    for a negative value."""
    value = getattr(params, name)
    if value < 0:
        raise ParameterError(f"{name} must be >= 0 (0 means {meaning}), got {value}")
    return value if value > 0 else from_seed


def check_positive(params: object, *names: str) -> None:
    """Raise :class:`ParameterError` for the first of ``names`` whose value in ``params`` is not a
    positive finite number (NaN compares false with everything, so ``<= 0`` alone lets it through)."""
    for name in names:
        value = getattr(params, name)
        if not (math.isfinite(value) and value > 0):
            raise ParameterError(f"{name} must be positive, got {value}")


def check_between(params: object, name: str, low: float, high: float, why: str) -> None:
    """Raise :class:`ParameterError` unless ``low <= value <= high`` for the field ``name`` of ``params``
    (false for NaN); ``why`` says what the bounds protect."""
    value = getattr(params, name)
    if not low <= value <= high:
        raise ParameterError(f"{name} must lie in [{low:g}, {high:g}] ({why}), got {value}")


# -- robust interdependence ------------------------------------------------------------
INTERLOCK_MARGIN = MakerInput.interlock_margin
"""Default shrink (metres) of every collision shape when the Maker asks whether an object is
needed: 1 % of the unit every generator builds on (grid cells, pocket and slider pitch of 1 m,
bars of 1-5 m), a tenth of the smallest clearance any generator leaves (0.1 m), and about
the play of a real gripper on a handle (docs/generators.md#interlock-margin)."""
MAX_INTERLOCK_MARGIN = 0.025
"""The measured margin tries up to 4x the required one (:mod:`solver.validation.judge`); past this the
top rung would shrink the generators' 0.1 m walls and doors to nothing."""


def interlock_margin_parameter() -> float:
    """The ``interlock_margin`` field every generator's parameters share."""
    return parameter(INTERLOCK_MARGIN, f"metres every collision shape is shrunk by when the Maker asks whether "
                                       f"an object is needed, 0..{MAX_INTERLOCK_MARGIN} (an object that leaves "
                                       f"less slack than this counts as superfluous)")


def check_interlock_margin(params: object) -> None:
    check_between(params, "interlock_margin", 0.0, MAX_INTERLOCK_MARGIN,
                  "4x it must leave the 0.1 m walls standing")


# -- geometry: bodies, handles, hinges, scenery -------------------------------------------
AT_FRAME = Pose()

HANDLE_SHAFT_WIDTH = 0.2
"""Width of a box shaft, diameter of a round one (the prototype's 0.2 x 0.2 x h shaft)."""
HANDLE_SHAFT_HEIGHT = 0.5
KNOB_SIZE: Vec3 = (0.05, 0.05, 0.2)
"""Full extent of the yellow knob on top of a shaft, where a gripper takes hold."""
KNOB_NAME = "knob"
HINGE_OVERHANG = 0.1
"""How much longer than its body a hinge pin is (sticking out above and below)."""


def box_geometry(size: Vec3, color: RGBA, origin: Pose = AT_FRAME, name: str = "body") -> Geometry:
    """A box (full extent ``size``) at ``origin`` in the link frame; by default the body."""
    return Geometry(Box(size), origin, color, name)


def handle(top: float, at: tuple[float, float] = (0.0, 0.0), color: RGBA = GRAY,
           shaft_width: float = HANDLE_SHAFT_WIDTH, shaft_height: float = HANDLE_SHAFT_HEIGHT,
           round_shaft: bool = False) -> tuple[Geometry, Geometry]:
    """A shaft standing on the body top (``top`` = its height above the link frame) at
    ``at`` in the link frame, and a yellow knob on the shaft.

    The shaft is a box ``shaft_width`` across, or with ``round_shaft`` a cylinder of
    that diameter. Both parts are physical (the caller puts them in visuals and
    collisions): a handle that passed through other objects could not be grasped.
    """
    x, y = at
    shape = Cylinder(shaft_width / 2, shaft_height) if round_shaft else Box((shaft_width, shaft_width, shaft_height))
    shaft = Geometry(shape, Pose((x, y, top + shaft_height / 2)), color, "handle_shaft")
    knob = Geometry(Box(KNOB_SIZE), Pose((x, y, top + shaft_height + KNOB_SIZE[2] / 2)), YELLOW, KNOB_NAME)
    return shaft, knob


def hinge(radius: float, length: float) -> Geometry:
    """A visual-only hinge pin on the joint axis (callers keep it out of collisions)."""
    return Geometry(Cylinder(radius, length), Pose(), GRAY, "hinge")


def fixed_box(name: str, x: float, y: float, size: Vec3, color: RGBA = GRAY,
              yaw: float = 0.0) -> PuzzleObject:
    """A box of scenery standing on the floor, centred at (x, y)."""
    body = box_geometry(size, color)
    return PuzzleObject(name, Motion.FIXED, Pose.planar(x, y, size[2] / 2, yaw), (body,), (body,),
                        Role.STATIC, ())


def wall(index: int, x: float, y: float, size: Vec3) -> PuzzleObject:
    return fixed_box(fixed_name(index, "wall"), x, y, size, GRAY)


def pillar(index: int, x: float, y: float, size: Vec3) -> PuzzleObject:
    return fixed_box(fixed_name(index, "pillar"), x, y, size, BLACK)


# -- grid cells, directions, transformation sets ------------------------------------
Cell = tuple[int, int]
"""A cell (i, j) of a unit grid; each generator says where its cells lie."""
Direction = tuple[int, int]
"""An axis-aligned unit vector: (1, 0), (0, 1), (-1, 0) or (0, -1)."""

AXIS_DIRECTIONS: tuple[Direction, ...] = ((1, 0), (0, 1), (-1, 0), (0, -1))
"""+x, +y, -x, -y: the directions of 0, 90, 180 and 270 degrees."""
QUARTER_TURNS = (0.0, 90.0, 180.0, 270.0)
"""The transformation set {0, 90, 180, 270} degrees of paper Table I."""
HALF_TURNS = (0.0, 180.0)
"""The transformation set {0, 180} degrees of paper Table I."""


def axis_direction(degrees: float) -> Direction:
    """The direction of an axis-aligned angle (0: +x, 90: +y, 180: -x, 270: -y)."""
    quarters = degrees / 90.0
    if abs(quarters - round(quarters)) > 1e-9:
        raise ValueError(f"angle {degrees} is not a multiple of 90 degrees")
    return AXIS_DIRECTIONS[round(quarters) % 4]


def turn_left(direction: Direction) -> Direction:
    """``direction`` turned by +90 degrees."""
    return (-direction[1], direction[0])


def add_cells(cell: Cell, *steps: Cell) -> Cell:
    """``cell`` moved by every step in ``steps``."""
    return (cell[0] + sum(s[0] for s in steps), cell[1] + sum(s[1] for s in steps))


def scale_cell(step: Cell, factor: int) -> Cell:
    return (step[0] * factor, step[1] * factor)


def ahead(point: tuple[float, float], direction: Direction, distance: float) -> tuple[float, float]:
    """The point ``distance`` from ``point`` along ``direction``."""
    return (point[0] + distance * direction[0], point[1] + distance * direction[1])


def direction_yaw(direction: Direction) -> float:
    """The yaw (radians) of a link whose x axis points along ``direction``."""
    return math.atan2(direction[1], direction[0])


# -- floor areas --------------------------------------------------------------------
OVERLAP_TOLERANCE = 1e-6
"""Metres two floor areas may interpenetrate and still count as merely touching."""


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle on the floor: [x_low, x_high] x [y_low, y_high]."""

    x_low: float
    y_low: float
    x_high: float
    y_high: float

    @staticmethod
    def along(start: tuple[float, float], direction: Direction, back: float, front: float,
              half_width: float) -> Rect:
        """The rectangle from ``start - back*direction`` to ``start + front*direction``,
        ``half_width`` to either side; ``direction`` is an axis-aligned unit vector.
        A slider's swept area: back = half its length, front = that plus its stroke."""
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


@dataclass(frozen=True)
class OrientedRect:
    """A rectangle on the floor at any yaw: centre, yaw and half extents along its own axes
    (a box's floor area at one pose)."""

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


FloorArea = Rect | Circle | OrientedRect


def overlaps(a: FloorArea, b: FloorArea, tolerance: float = OVERLAP_TOLERANCE) -> bool:
    """True when two floor areas interpenetrate by more than ``tolerance`` (touching is fine).

    The same rule as the solver's collision model, so a start pose accepted
    here is valid there.
    """
    if isinstance(a, OrientedRect) or isinstance(b, OrientedRect):
        return _oriented_overlap(a, b, tolerance)
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


def _as_oriented(area: Rect | OrientedRect) -> OrientedRect:
    if isinstance(area, OrientedRect):
        return area
    return OrientedRect((area.x_low + area.x_high) / 2, (area.y_low + area.y_high) / 2, 0.0,
                        (area.x_high - area.x_low) / 2, (area.y_high - area.y_low) / 2)


def _oriented_overlap(a: FloorArea, b: FloorArea, tolerance: float) -> bool:
    if isinstance(a, Circle):
        a, b = b, a
    a = _as_oriented(a)  # type: ignore[arg-type]
    if isinstance(b, Circle):
        # The circle in the rectangle's own frame, where the rectangle is axis-aligned.
        c, s = math.cos(a.yaw), math.sin(a.yaw)
        dx, dy = b.x - a.x, b.y - a.y
        local = Circle(c * dx + s * dy, -s * dx + c * dy, b.radius)
        return overlaps(Rect(-a.half_x, -a.half_y, a.half_x, a.half_y), local, tolerance)
    b = _as_oriented(b)
    # Separating axes: the four edge normals.
    corners_a, corners_b = a.corners(), b.corners()
    for yaw in (a.yaw, b.yaw):
        for nx, ny in ((math.cos(yaw), math.sin(yaw)), (-math.sin(yaw), math.cos(yaw))):
            pa = [nx * x + ny * y for x, y in corners_a]
            pb = [nx * x + ny * y for x, y in corners_b]
            if min(max(pa), max(pb)) - max(min(pa), min(pb)) <= tolerance:
                return False
    return True


# -- the Maker's input ----------------------------------------------------------------------
def paper_input(params: object, **items) -> MakerInput:
    """A generator's Maker input (``items``: its fields) with the parameters' interlock margin and, unless
    ``goal`` is among ``items``, the paper's goal rule for the target (:func:`target_paper_goal`)."""
    return MakerInput(interlock_margin=params.interlock_margin, **{"goal": target_paper_goal, **items})


# -- goals --------------------------------------------------------------------------------
def target_paper_goal(draft: Draft) -> Goal:
    """The paper's goal rule for the draft's target (its first object): a prismatic target
    at the far end of its limits, a revolute one turned 90 degrees the way its limits allow."""
    return paper_goal(draft.objects[0])
