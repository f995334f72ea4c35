"""Rooms (paper Table I): a robot escapes a chain of rooms laid along a self-avoiding walk.

Geometry is written in cell units (a room is a 1 x 1 cell, the prototype's
numbers) and multiplied by ``scaling`` exactly once, in :func:`_scaled`; the
goal goes through the same function.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry import Pose, Vec3
from ..maker import Choice, Draft, MakerInput
from ..objects import Motion, PuzzleObject
from ..puzzle import Goal
from ..registry import ParameterError, parameter, register
from . import kit

# Room cell (i, j) is the unit square centred on (i, j), before scaling.
ROOM = "room"
DOOR_ROOM = "door_room"
DOOR_PANEL_FRACTION = 0.8
"""Door panel length / doorway width (prototype); the hinge sits 0.4 doorway widths off centre."""
ROBOT_SIZE: Vec3 = (0.09375, 0.125, 0.125)
"""The prototype's robot (a droid mesh there) as a box, in cell units."""
HANDLE_FRACTION = 0.75
"""Where along the panel (from the hinge) the door's handle stands."""
MAX_ROOMS = 6
"""The most rooms accepted (with any number of doors, at the largest scaling): 6 rooms with 6 doors
take up to about 1 min of CPU time, 7 with 7 doors over 2 min (docs/generators.md#feasible-sizes).
Two-digit names of walls and pillars alone would allow 12."""
SCALING = (1.0, 4.0)
"""Accepted metres per cell unit, up to the paper's 4. Generation time grows with the scale (the
validator checks states 0.02 m apart, so longer paths take more checks): 6 rooms with 6 doors at
scaling 8 took over 2 min of CPU time. Below 1 the robot (0.09 cell units across) would be only a
few checks wide."""
MIN_WALL_THICKNESS = 0.01
"""Cell units (so at least 0.01 m at the smallest scaling): far above the collision model's 1e-6 m
contact tolerance, below which a wall would count as touched, not hit, and block nothing."""
WALL_HEIGHT = (0.01, 10.0)


@dataclass(frozen=True)
class RoomsParams:
    """Parameters of Rooms. Lengths are in cell units (a room is 1 x 1) before ``scaling``,
    as in the prototype."""

    n_rooms: int = parameter(4, f"how many rooms the robot must cross, 1..{MAX_ROOMS} (Table I: 4)",
                             difficulty=True)
    doors: int = parameter(2, "how many of the rooms' doorways have a door to open (0..n_rooms)",
                           difficulty=True)
    scaling: float = parameter(4.0, f"metres per cell unit, applied once to every length and to the goal "
                                    f"({SCALING[0]:g}..{SCALING[1]:g})")
    wall_height: float = parameter(0.2, f"height of walls, pillars and doors (cell units, {WALL_HEIGHT[0]:g}.."
                                        f"{WALL_HEIGHT[1]:g})")
    wall_thickness: float = parameter(0.075, f"thickness of walls and doors, side of the corner pillars "
                                             f"(cell units, at least {MIN_WALL_THICKNESS:g})", difficulty=True)
    door_width: float = parameter(0.5, "width of a doorway (cell units); a closed door must block the robot "
                                       "and an open one let it pass", difficulty=True)
    interlock_margin: float = kit.interlock_margin_parameter()

    def validate(self, seed: int) -> None:
        kit.check_interlock_margin(self)
        kit.check_count("n_rooms", self.n_rooms, 1, MAX_ROOMS,
                        f"generation time grows steeply with rooms and doors (6 rooms, 6 doors: up to about "
                        f"1 min of CPU time; 7 and 7: over 2 min; {kit.SIZES_DOC})")
        if not 0 <= self.doors <= self.n_rooms:
            raise ParameterError(f"doors must lie in 0..n_rooms = {self.n_rooms}, got {self.doors}")
        kit.check_positive(self, "scaling", "wall_height", "wall_thickness", "door_width")
        kit.check_between(self, "scaling", *SCALING, "generation time grows with the scale, 6 rooms at scaling 8 "
                                                    "take over 2 min; below 1 the robot is only a few validation "
                                                    "steps across")
        kit.check_between(self, "wall_height", *WALL_HEIGHT, "a sane size; the height changes only the look")
        kit.check_between(self, "wall_thickness", MIN_WALL_THICKNESS, 1.0,
                          "thinner walls would pass for contact, not collision")
        if 2 * self.wall_thickness + self.door_width >= 1.0:
            raise ParameterError(
                f"doorway {self.door_width} plus two pillars {self.wall_thickness} must be narrower than "
                f"a room (1): reduce door_width or wall_thickness"
            )
        gap = (1 - DOOR_PANEL_FRACTION) / 2 * self.door_width
        opening = (1 + DOOR_PANEL_FRACTION) / 2 * self.door_width - self.wall_thickness / 2
        smallest, largest = min(ROBOT_SIZE[:2]), max(ROBOT_SIZE[:2])
        if not gap < smallest:
            raise ParameterError(
                f"a closed door leaves {gap:.4g} beside it, which the robot ({smallest} across) would slip "
                f"through: make door_width smaller than {smallest / gap * self.door_width:.4g}"
            )
        if not largest < opening:
            raise ParameterError(
                f"an open door leaves {opening:.4g}, too narrow for the robot ({largest} across): "
                f"widen door_width or thin the walls"
            )


@dataclass(frozen=True)
class _Walk:
    """The rooms placed so far (their cells, in order) and the cell the last one exits to."""

    rooms: tuple[kit.Cell, ...]
    exit_cell: kit.Cell
    exits: tuple[kit.Direction, ...]  # exit direction of every room
    doors: int

    @property
    def cells(self) -> tuple[kit.Cell, ...]:
        return (*self.rooms, self.exit_cell)


def _scaled(params: RoomsParams, value: float) -> float:
    return value * params.scaling


def _robot(params: RoomsParams, walk_cells: tuple[kit.Cell, ...]) -> PuzzleObject:
    """The target: an R^2 robot at the centre of the first room; its limits are the
    bounding box of the cells visited so far (the prototype's rule)."""
    size = tuple(_scaled(params, v) for v in ROBOT_SIZE)
    xs = [c[0] for c in walk_cells]
    ys = [c[1] for c in walk_cells]
    limits = ((_scaled(params, min(xs) - 0.5), _scaled(params, max(xs) + 0.5)),
              (_scaled(params, min(ys) - 0.5), _scaled(params, max(ys) + 0.5)))
    role, color = kit.role_and_color(0)
    geometry = (kit.box_geometry(size, color), *kit.handle(size[2] / 2, color=color))  # type: ignore[arg-type]
    return PuzzleObject(kit.movable_name(0), Motion.R2, Pose.planar(0.0, 0.0, size[2] / 2), geometry, geometry,
                        role, limits)


def _room(params: RoomsParams, cell: kit.Cell, exit_dir: kit.Direction, entry_dir: kit.Direction | None,
          first: int) -> tuple[PuzzleObject, ...]:
    """Pillars and walls of one room, inside its own cell: a doorway on the exit side,
    nothing on the side it is entered from, full walls elsewhere."""
    t, dw = params.wall_thickness, params.door_width
    h = _scaled(params, params.wall_height)
    inset = (1 - t) / 2  # cell centre to the middle of a wall
    out: list[PuzzleObject] = []

    def place(kind, cx: float, cy: float, along: float, across: float, d: kit.Direction) -> None:
        # ``along`` runs parallel to the side facing ``d``.
        sx, sy = (along, across) if d[1] != 0 else (across, along)
        size = (_scaled(params, sx), _scaled(params, sy), h)
        out.append(kind(first + len(out), _scaled(params, cx), _scaled(params, cy), size))

    for d in kit.AXIS_DIRECTIONS:
        a = kit.turn_left(d)
        px, py = cell[0] + (d[0] + a[0]) * inset, cell[1] + (d[1] + a[1]) * inset
        place(kit.pillar, px, py, t, t, d)
        mx, my = cell[0] + d[0] * inset, cell[1] + d[1] * inset
        if d == exit_dir:
            segment = (1 - 2 * t - dw) / 2
            offset = (segment + dw) / 2
            for sign in (-1, 1):
                place(kit.wall, mx + sign * offset * a[0], my + sign * offset * a[1], segment, t, d)
        elif d != entry_dir:
            place(kit.wall, mx, my, 1 - 2 * t, t, d)
    return tuple(out)


def _door(params: RoomsParams, index: int, cell: kit.Cell, exit_dir: kit.Direction) -> PuzzleObject:
    """A revolute door in the exit doorway, hinged beside it and opening (0 .. 90 degrees)
    into the room."""
    t, dw = params.wall_thickness, params.door_width
    inset = (1 - t) / 2
    along = (exit_dir[1], -exit_dir[0])  # the doorway axis, turned -90 degrees from the exit
    hx = cell[0] + exit_dir[0] * inset + along[0] * dw * DOOR_PANEL_FRACTION / 2
    hy = cell[1] + exit_dir[1] * inset + along[1] * dw * DOOR_PANEL_FRACTION / 2
    # The panel reaches from the hinge back across the doorway; turning it by +90 degrees
    # points it at the room centre (-exit_dir), into the room.
    yaw = math.atan2(-along[1], -along[0])
    length = _scaled(params, dw * DOOR_PANEL_FRACTION)
    thickness = _scaled(params, t)
    height = _scaled(params, params.wall_height)
    role, color = kit.role_and_color(index)
    panel = kit.box_geometry((length, thickness, height), color, Pose((length / 2, 0.0, 0.0)))
    shaft, knob = kit.handle(height / 2, (HANDLE_FRACTION * length, 0.0), color,
                         shaft_width=min(kit.HANDLE_SHAFT_WIDTH, thickness))
    visuals = (panel, shaft, knob, kit.hinge(0.55 * thickness, 1.1 * height))
    return PuzzleObject(kit.movable_name(index), Motion.REVOLUTE,
                        Pose.planar(_scaled(params, hx), _scaled(params, hy), height / 2, yaw),
                        visuals, (panel, shaft, knob), role, ((0.0, math.pi / 2),))


def _attach_for(params: RoomsParams):
    def attach(draft: Draft, obj_item: str, joint_item: Motion, tf_item: float, n: int,
               rng: np.random.Generator) -> Draft | None:
        walk: _Walk = draft.context
        cell = walk.exit_cell
        exit_dir = kit.axis_direction(tf_item)
        next_cell = kit.add_cells(cell, exit_dir)
        if next_cell in walk.cells:
            return None  # the walk must not cross itself
        rooms_left = params.n_rooms - n
        if rooms_left > 0 and all(kit.add_cells(next_cell, d) in walk.cells + (next_cell,)
                                  for d in kit.AXIS_DIRECTIONS):
            return None  # a dead end: the next room would have nowhere to exit
        with_door = obj_item == DOOR_ROOM
        doors = walk.doors + int(with_door)
        if doors > params.doors or params.doors - doors > rooms_left:
            return None  # keep exactly ``params.doors`` doors over all rooms
        entry_dir = (-walk.exits[-1][0], -walk.exits[-1][1]) if walk.exits else None
        new_walk = _Walk((*walk.rooms, cell), next_cell, (*walk.exits, exit_dir), doors)
        room = _room(params, cell, exit_dir, entry_dir, kit.count_fixed(draft.objects))
        added = list(room)
        if with_door:
            added.append(_door(params, kit.count_movable(draft.objects), cell, exit_dir))
        # The robot's workspace grows with the walk: it is re-issued with wider limits,
        # every other object is kept as it was.
        robot = _robot(params, new_walk.cells)
        return Draft((robot, *draft.objects[1:], *added), new_walk)

    return attach


def _goal_for(params: RoomsParams):
    def goal(draft: Draft) -> Goal:
        walk: _Walk = draft.context
        robot = draft.objects[0]
        x, y = walk.exit_cell
        values = {f"{robot.name}_x": _scaled(params, x), f"{robot.name}_y": _scaled(params, y)}
        return Goal(robot.name, values)

    return goal


@register("rooms", "Rooms", RoomsParams, paper_row=6, time_limits={"paper": 60.0, "quick": 6.0},
          scene_scale=0.125)
def build(seed: int, params: RoomsParams) -> MakerInput:
    """Rooms: a robot must get out of a chain of rooms, through doors it has to open.

    Mechanism:
        The target (``obj_00``) is the robot, an R^2 object (x, y; no turning),
        0.375 x 0.5 x 0.5 after scaling, at the centre of the first room. Rooms
        are 1 x 1 cells (4 x 4 m after scaling 4) with black corner pillars and
        gray walls (0.075 thick, 0.2 high before scaling), placed along a
        self-avoiding walk. Each room has a doorway (0.5 wide) on its exit
        side, no wall on the side it is entered from, and full walls
        elsewhere, so the robot can only leave through the chain of doorways.
        A door room also holds a red revolute door panel (0.8 of the doorway,
        hinged 0.4 doorway widths off centre, limits 0 .. 90 degrees, opening
        into the room) closing its doorway: the robot must open it to pass.

    Randomization:
        Table I: objects {Room, Door Room}, joints {Fixed}, transformations
        {0, 90, 180, 270} degrees (the room's exit side), 4 objects (rooms).
        The seeded Maker picks each room's kind and exit; attach refuses
        (returns None, the Maker draws again) an exit into a visited cell or a
        dead end, and a kind that would not end with exactly ``doors`` doors.

    Goal:
        The robot at the centre of the cell the last room exits to (scaled
        like everything else), which is outside every room and within the
        robot's limits.

    Difficulty parameters:
        ``n_rooms`` (length of the escape), ``doors`` (how many doorways have
        doors), ``door_width`` and ``wall_thickness`` (cell units; validated so
        that a closed door blocks the robot and an open one lets it pass).
        ``wall_height`` and ``scaling`` change only the size.

    Departures:
        The robot is not a Maker item (Table I lists only rooms): it is
        ``MakerInput.initial``, present before the first room, and re-issued
        each iteration with limits that cover the cells visited so far.
        Scaling is applied once, to positions, sizes and the goal alike. Doors
        carry a handle on top rather than hooks on both faces.

    Design notes: docs/generators.md#rooms
    """
    params.validate(seed)
    start = _Walk((), (0, 0), (), 0)
    return MakerInput(
        interlock_margin=params.interlock_margin,
        objects=Choice((ROOM, DOOR_ROOM)),
        joints=Choice((Motion.FIXED,)),
        # The transformation is the room's exit side: 0 east, 90 north, 180 west, 270 south.
        transforms=Choice(kit.QUARTER_TURNS),
        n_objects=params.n_rooms,
        attach=_attach_for(params),
        goal=_goal_for(params),
        initial=Draft((_robot(params, ((0, 0),)),), start),
    )
