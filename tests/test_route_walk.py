"""A routed re-plan's legs without search (:func:`solver.validation.route_grid.walk_leg`): a way along
the route is kept only when every motion is free at 2 mm, a way through a wall is refused, and a leg
whose route cannot be walked is still planned, by RRT-Connect as before."""

from __future__ import annotations

import math

import numpy as np
import pytest

from phyrogen_core.chain import Geometry, Role
from phyrogen_core.geometry import Box, Pose
from phyrogen_core.objects import Motion, PuzzleObject, build_chain
from phyrogen_core.puzzle import Goal
from solver.planning.problem import DEFAULT_RESOLUTION, FINE_RESOLUTION, in_goal, path_is_valid, problem_for_chain
from solver.validation.route_grid import Route, walk_leg
from solver.validation.validator import OmplValidator

GOAL = Goal("obj_00", {"obj_00_x": 1.8, "obj_00_y": 0.0}, 0.05)
AROUND = np.array([(0.0, 0.8), (1.8, 0.8), (1.8, 0.0)])
THROUGH = np.array([(0.6, 0.0), (1.0, 0.0), (1.4, 0.0), (1.8, 0.0)])
TURNS = [{2: math.pi / 4}, {2: math.pi / 2}]


def _box(size):
    return (Geometry(Box(size)),)


def _problem(wall: bool = True, door: bool = False):
    """A 0.3 m target at the origin, free in x, y and yaw; a 1 m wall across its straight way to
    x = 1.8 (or none); a sliding door that closes the gap above the wall (or none)."""
    objects = [PuzzleObject("obj_00", Motion.SE2, Pose.planar(0.0, 0.0, 0.15), _box((0.3, 0.3, 0.3)),
                            _box((0.3, 0.3, 0.3)), Role.TARGET, ((-2.0, 2.0), (-2.0, 2.0), (-math.pi, math.pi)))]
    if wall:
        objects.append(PuzzleObject("fixed_01_wall", Motion.FIXED, Pose.planar(1.0, 0.0, 0.15),
                                    _box((0.2, 1.0, 0.3)), _box((0.2, 1.0, 0.3)), Role.STATIC))
    if door:  # slides in x along y = 0.8; at 0 it fills the gap between the wall and y = 1.3
        objects.append(PuzzleObject("obj_02", Motion.PRISMATIC, Pose.planar(1.0, 0.9, 0.15),
                                    _box((0.2, 0.8, 0.3)), _box((0.2, 0.8, 0.3)), Role.BLOCKER, ((-1.5, 0.0),)))
    problem = problem_for_chain(build_chain(objects), GOAL)
    return objects, problem


def _end(problem):
    end = problem.start.copy()
    end[list(problem.goal_columns)] = list(problem.goal_columns.values())
    return end


def _walk(problem, points, turns=(), doors=()):
    model = problem.model
    return walk_leg(model, problem.start, points, _end(problem), (0, 1), list(turns), list(doors),
                    model.motion_steps(FINE_RESOLUTION), model.motion_steps(DEFAULT_RESOLUTION))


def _holds(problem, states) -> bool:
    return path_is_valid(problem.model, states, problem.model.motion_steps(FINE_RESOLUTION))


def test_an_open_leg_is_one_straight_motion():
    _, problem = _problem(wall=False)
    states, checks = _walk(problem, THROUGH)
    assert len(states) == 2 and checks == 2  # screened, then checked at 2 mm
    assert _holds(problem, states) and in_goal(problem, states[-1])


def test_a_leg_around_a_wall_follows_the_route_and_every_motion_holds_at_2_mm():
    _, problem = _problem()
    states, _ = _walk(problem, AROUND)
    assert states is not None and len(states) == 4  # the straight motion is refused, the route's kept
    assert _holds(problem, states) and in_goal(problem, states[-1])
    # the control: the straight motion it refused does cross the wall
    assert not _holds(problem, np.stack([problem.start, _end(problem)]))


def test_a_route_through_a_wall_is_refused_however_the_target_turns():
    _, problem = _problem()
    states, checks = _walk(problem, THROUGH, TURNS)
    assert states is None and checks > 0


def test_a_closed_door_is_opened_alone_before_the_target_walks():
    _, problem = _problem(door=True)
    door = problem.model.joint_order.index("obj_02")
    assert _walk(problem, AROUND, TURNS)[0] is None  # the control: with the door held, no way
    states, _ = _walk(problem, AROUND, TURNS, [{door: -1.5}])
    assert states is not None and _holds(problem, states) and in_goal(problem, states[-1])
    moves = np.abs(np.diff(states, axis=0)) > 1e-12
    assert moves[0, door] and not moves[0, :3].any()  # the door moves first, alone
    assert not moves[1:, door].any()


@pytest.mark.parametrize("points", [THROUGH, AROUND])
def test_a_routed_leg_is_planned_whether_or_not_its_route_can_be_walked(points):
    objects, problem = _problem()
    validator = OmplValidator(np.random.default_rng(3), routed=True)
    route = Route((0, 1), (0, 1, 2), [(np.vstack([[0.0, 0.0], points]), points[-1])])
    path = validator._plan_leg(problem, route, problem.start, route.legs[0][0], problem.goal_columns,
                               problem.tolerance, FINE_RESOLUTION)
    assert path is not None and _holds(problem, path) and in_goal(problem, path[-1])
    walked = points is AROUND
    assert (validator.checks < 100) == walked  # RRT-Connect spends thousands where the route was blocked
