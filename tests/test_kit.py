"""The generators' shared kit: names, handles, floor areas, directions, the paper's goal."""

from __future__ import annotations

import math

import pytest

from phyrogen_core.chain import GRAY, GREEN, RED, YELLOW, Role
from phyrogen_core.generators.kit import (
    AXIS_DIRECTIONS,
    MAX_OBJECTS,
    QUARTER_TURNS,
    Circle,
    OrientedRect,
    Rect,
    add_cells,
    ahead,
    axis_direction,
    box_geometry,
    check_object_count,
    count_fixed,
    count_movable,
    direction_yaw,
    fixed_name,
    handle,
    hinge,
    movable_name,
    overlaps,
    pillar,
    role_and_color,
    target_paper_goal,
    turn_left,
    wall,
)
from phyrogen_core.geometry import Box, Cylinder, Pose
from phyrogen_core.maker import Draft
from phyrogen_core.objects import Motion, PuzzleObject
from phyrogen_core.registry import ParameterError


def test_names_roles_and_colours():
    assert movable_name(0) == "obj_00" and movable_name(MAX_OBJECTS - 1) == "obj_99"
    assert fixed_name(3, "wall") == "fixed_03_wall"
    with pytest.raises(ValueError, match="two-digit"):
        movable_name(MAX_OBJECTS)
    assert role_and_color(0) == (Role.TARGET, GREEN)
    assert role_and_color(5) == (Role.BLOCKER, RED)
    scenery = (wall(0, 0.0, 0.0, (1.0, 0.1, 0.5)), pillar(1, 1.0, 0.0, (0.1, 0.1, 0.5)))
    assert [o.name for o in scenery] == ["fixed_00_wall", "fixed_01_pillar"]
    assert count_fixed(scenery) == 2 and count_movable(scenery) == 0
    assert all(o.motion is Motion.FIXED and o.role is Role.STATIC for o in scenery)
    assert scenery[0].pose.xyz[2] == 0.25  # standing on the floor
    with pytest.raises(ParameterError, match="n_objects must lie in 1..99, got 100"):
        check_object_count(100)


def test_handles_stand_on_the_body_with_a_knob_on_top():
    shaft, knob = handle(0.1, (0.3, 0.0), RED)
    assert shaft.shape == Box((0.2, 0.2, 0.5)) and shaft.origin.xyz == (0.3, 0.0, 0.35)
    assert shaft.color == RED and shaft.name == "handle_shaft"
    assert knob.name == "knob" and knob.color == YELLOW and knob.origin.xyz == pytest.approx((0.3, 0.0, 0.7))
    round_shaft, _ = handle(0.5, round_shaft=True)
    assert round_shaft.shape == Cylinder(0.1, 0.5)
    thin, _ = handle(0.5, shaft_width=0.1)
    assert thin.shape == Box((0.1, 0.1, 0.5))
    pin = hinge(0.1, 1.1)
    assert pin.shape == Cylinder(0.1, 1.1) and pin.color == GRAY and pin.name == "hinge"
    assert box_geometry((1.0, 2.0, 3.0), GREEN).name == "body"


def test_directions_and_cells():
    assert [axis_direction(a) for a in QUARTER_TURNS] == list(AXIS_DIRECTIONS)
    assert axis_direction(-90.0) == (0, -1) and axis_direction(450.0) == (0, 1)
    with pytest.raises(ValueError, match="45"):
        axis_direction(45.0)
    assert [turn_left(d) for d in AXIS_DIRECTIONS] == list(AXIS_DIRECTIONS[1:] + AXIS_DIRECTIONS[:1])
    assert add_cells((1, 2), (1, 0), (0, -1)) == (2, 1) and add_cells((1, 2)) == (1, 2)
    assert ahead((1.0, 1.0), (0, -1), 2.5) == (1.0, -1.5)
    assert direction_yaw((0, 1)) == pytest.approx(math.pi / 2)


def test_swept_rectangle_along_a_direction():
    assert Rect.along((0.0, 0.0), (1, 0), 0.5, 1.5, 0.1) == Rect(-0.5, -0.1, 1.5, 0.1)
    assert Rect.along((0.0, 0.0), (0, -1), 0.5, 1.5, 0.1) == Rect(-0.1, -1.5, 0.1, 0.5)


@pytest.mark.parametrize(("a", "b", "expected"), [
    (Rect(0, 0, 1, 1), Rect(0.5, 0.5, 2, 2), True),
    (Rect(0, 0, 1, 1), Rect(1, 0, 2, 1), False),  # touching is not overlapping
    (Circle(0, 0, 1), Circle(2, 0, 1), False),
    (Circle(0, 0, 1), Circle(1.9, 0, 1), True),
    (Rect(0, 0, 1, 1), Circle(2, 0.5, 1), False),
    (Circle(1.9, 0.5, 1), Rect(0, 0, 1, 1), True),
    (Rect(-1, -1, 1, 1), Circle(0, 0, 0.1), True),  # inside
    (OrientedRect(0, 0, 0.0, 1, 1), OrientedRect(2, 0, 0.0, 1, 1), False),
    (OrientedRect(0, 0, math.pi / 4, 1, 1), OrientedRect(2, 0, 0.0, 1, 1), True),
    (OrientedRect(0, 0, math.pi / 4, 1, 0.1), OrientedRect(0, 0, -math.pi / 4, 1, 0.1), True),
    # Mixed: an axis-aligned rectangle or a circle against an oriented one.
    (Rect(1, -1, 3, 1), OrientedRect(0, 0, 0.0, 1, 1), False),
    (OrientedRect(0, 0, math.pi / 4, 1, 1), Rect(1, -1, 3, 1), True),
    (Circle(2, 0, 1), OrientedRect(0, 0, 0.0, 1, 1), False),
    (OrientedRect(0, 0, math.pi / 4, 1, 1), Circle(2.3, 0, 1), True),
])
def test_overlaps_counts_only_interpenetration(a, b, expected):
    assert overlaps(a, b) is expected
    assert overlaps(b, a) is expected


def test_target_paper_goal_uses_the_first_object():
    body = box_geometry((1.0, 0.2, 0.2), GREEN)
    target = PuzzleObject("obj_00", Motion.PRISMATIC, Pose(), (body,), (body,), Role.TARGET, ((0.0, 1.0),))
    blocker = PuzzleObject("obj_01", Motion.PRISMATIC, Pose(), (body,), (body,), Role.BLOCKER, ((-2.0, 0.0),))
    goal = target_paper_goal(Draft((target, blocker)))
    assert goal.target == "obj_00" and list(goal.values.values()) == [1.0]
