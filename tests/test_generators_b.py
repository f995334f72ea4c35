"""Continuous Space, Move N Times and Rooms: parameters, layout, mechanism.

What every generator must guarantee (names, roles, handles, a free start,
determinism, documented parameters) is tested over the whole registry in
``test_registry.py``; this file tests what is particular to these three.
Most tests run the Maker with a validator that accepts every candidate (no
planner), so they check what the generators build, not what the planner
finds; the end-to-end tests at the bottom go through the real validator.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from maker_support import run

from phyrogen_core.maker import MakerResult
from phyrogen_core.objects import Motion, build_chain
from phyrogen_core.registry import ParameterError, get_generator
from solver.collision.model import CollisionModel

NAMES = ("continuous_space", "move_n_times", "rooms")


def start_model(result: MakerResult) -> CollisionModel:
    return CollisionModel(build_chain(result.objects))


def state_with(model: CollisionModel, **values: float) -> np.ndarray:
    return np.array([values.get(name, 0.0) for name in model.joint_order])


# -- parameters ------------------------------------------------------------------
@pytest.mark.parametrize(("name", "overrides", "needle"), [
    ("continuous_space", {"n_objects": 0}, "n_objects"),
    ("continuous_space", {"n_objects": 100}, "100"),
    ("continuous_space", {"bar_width": 4.0}, "bar_width"),
    ("continuous_space", {"bar_height": -1.0}, "bar_height"),
    ("continuous_space", {"min_limit_deg": 45.0}, "45"),
    ("move_n_times", {"n": -1}, "-1"),
    ("move_n_times", {"n": 21}, "21"),
    ("rooms", {"n_rooms": 0}, "n_rooms"),
    ("rooms", {"n_rooms": 13}, "13"),
    ("rooms", {"doors": 5}, "doors"),
    ("rooms", {"door_width": 0.9}, "door_width"),
    ("rooms", {"door_width": 0.1}, "too narrow"),
    ("rooms", {"scaling": 0.0}, "scaling"),
])
def test_infeasible_parameters_are_named(name, overrides, needle):
    spec = get_generator(name)
    with pytest.raises(ParameterError, match=needle):
        spec.check(1, spec.parse_params(overrides))


def test_move_n_times_defaults_to_the_seed_and_caps_it():
    spec = get_generator("move_n_times")
    with pytest.raises(ParameterError, match="seed 21"):
        spec.check(21, spec.default_params())
    assert spec.parse_params({"n": "3"}).moves(7) == 3
    assert spec.default_params().moves(7) == 7


# -- Continuous Space --------------------------------------------------------------
def test_continuous_space_is_revolute_bars_turning_ninety_degrees():
    result = run("continuous_space", 5)
    assert len(result.objects) == 4
    assert all(o.motion is Motion.REVOLUTE for o in result.objects)
    for obj in result.objects:
        (lower, upper), = obj.limits
        magnitude = upper - lower
        assert math.radians(90) <= magnitude <= math.radians(180) and 0.0 in (lower, upper)
    (value,) = result.goal.values.values()
    assert abs(value) == pytest.approx(math.pi / 2)


def test_continuous_space_places_each_bar_in_the_swing_of_the_previous():
    result = run("continuous_space", 2, n_objects=6)
    length = get_generator("continuous_space").default_params().bar_length
    for previous, new in zip(result.objects, result.objects[1:], strict=False):
        distance = math.dist(previous.pose.xyz[:2], new.pose.xyz[:2])
        # Its near end is within reach of the previous bar's ends.
        assert distance - length / 2 < length / 2 + 1e-9


# -- Move N Times ------------------------------------------------------------------
@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_move_n_times_layout(n):
    result = run("move_n_times", n)
    target, door = result.objects[0], result.objects[1]
    assert target.motion is Motion.SE2 and door.motion is Motion.PRISMATIC
    assert target.limits[:2] == ((-n, n), (-n, 0.5))
    walls = [o for o in result.objects if not o.is_movable]
    assert len(walls) == (3 if n == 1 else 5 * n - 4)
    assert len(result.objects) == 2 + len(walls)
    assert result.goal.values["obj_00_y"] == -n
    assert -n <= result.goal.values["obj_00_x"] <= n


@pytest.mark.parametrize("n", [1, 3])
def test_move_n_times_door_slides_its_whole_range_and_the_goal_is_free(n):
    result = run("move_n_times", n)
    model = start_model(result)
    (lower, upper), = result.objects[1].limits
    away = {"obj_00_y": -n}  # the target out of the door's way, at the goal line
    for q in np.linspace(lower, upper, 41):
        assert model.is_valid(state_with(model, obj_01=q, **away)), f"door at {q} hits a wall"
    assert model.is_valid(state_with(model, **result.goal.values, obj_01=upper))


def door_moves_lower_bound(result: MakerResult, n: int, cell: float = 0.05) -> int:
    """Fewest door moves that get a disc (the target's inscribed one) from the pocket to
    the goal line, on a grid, letting the door jump between positions: a lower bound
    on the real puzzle's door moves."""
    target, door = result.objects[0], result.objects[1]
    walls = [o for o in result.objects if not o.is_movable]
    radius = min(target.collisions[0].shape.size[:2]) / 2
    xs, ys = np.arange(-n, n + 1e-9, cell), np.arange(-n, 0.5 + 1e-9, cell)
    grid_x, grid_y = np.meshgrid(xs, ys, indexing="ij")

    def clear_of(x, y, half_x, half_y):
        dx = np.maximum(np.abs(grid_x - x) - half_x, 0.0)
        dy = np.maximum(np.abs(grid_y - y) - half_y, 0.0)
        return np.hypot(dx, dy) >= radius - 1e-9

    free_of_walls = np.ones_like(grid_x, dtype=bool)
    for w in walls:
        sx, sy, _ = w.collisions[0].shape.size
        free_of_walls &= clear_of(w.pose.xyz[0], w.pose.xyz[1], sx / 2, sy / 2)
    (lower, upper), = door.limits
    length, thickness, _ = door.collisions[0].shape.size
    axis = math.cos(door.pose.yaw)
    free = [free_of_walls & clear_of(door.pose.xyz[0] + axis * q, door.pose.xyz[1], length / 2, thickness / 2)
            for q in np.arange(lower, upper + 1e-9, cell / 2)]

    def flood(seed, mask):
        current = seed & mask
        while True:
            grown = current.copy()
            grown[1:] |= current[:-1]
            grown[:-1] |= current[1:]
            grown[:, 1:] |= current[:, :-1]
            grown[:, :-1] |= current[:, 1:]
            grown &= mask
            if (grown == current).all():
                return current
            current = grown

    start = np.zeros_like(grid_x, dtype=bool)
    start[np.argmin(np.abs(xs)), np.argmin(np.abs(ys))] = True
    at_rest = int(np.argmin(np.abs(np.arange(lower, upper + 1e-9, cell / 2))))
    reached = flood(start, free[at_rest])
    for moves in range(3 * n + 3):
        if reached[:, 0].any():  # row 0 is the goal line y = -n
            return moves
        reached = np.logical_or.reduce([flood(reached, mask) for mask in free])
    raise AssertionError("the goal line is unreachable even with a teleporting door")


@pytest.mark.parametrize("n", [1, 2, 3])
def test_move_n_times_needs_n_door_moves(n):
    assert door_moves_lower_bound(run("move_n_times", n), n) == n


# -- Rooms -------------------------------------------------------------------------
def test_rooms_layout_and_goal():
    params = get_generator("rooms").default_params()
    for seed in (1, 2, 3):
        result = run("rooms", seed)
        robot, *rest = result.objects
        doors = [o for o in rest if o.is_movable]
        assert robot.motion is Motion.R2
        assert len(doors) == params.doors and all(o.motion is Motion.REVOLUTE for o in doors)
        assert all(o.limits == ((0.0, math.pi / 2),) for o in doors)
        assert len(rest) - len(doors) == 9 + 8 * (params.n_rooms - 1)
        # The goal is a cell centre (a multiple of the scaled cell), not the start cell.
        gx, gy = result.goal.values["obj_00_x"], result.goal.values["obj_00_y"]
        cells = (gx / params.scaling, gy / params.scaling)
        assert all(abs(c - round(c)) < 1e-9 for c in cells) and cells != (0, 0)
        assert 1 <= abs(round(cells[0])) + abs(round(cells[1])) <= params.n_rooms


def test_rooms_scaling_applies_to_geometry_and_goal_alike():
    small, large = run("rooms", 2, scaling=1.0), run("rooms", 2, scaling=4.0)
    for a, b in zip(small.objects, large.objects, strict=True):
        assert np.allclose(np.array(b.pose.xyz[:2]), 4 * np.array(a.pose.xyz[:2]))
    for joint, value in small.goal.values.items():
        assert large.goal.values[joint] == pytest.approx(4 * value)


def test_rooms_closed_door_blocks_the_robot_and_open_door_lets_it_pass():
    result = run("rooms", 1)
    model = start_model(result)
    robot = result.objects[0]
    for door in [o for o in result.objects[1:] if o.is_movable]:
        # The doorway centre: 0.4 doorway widths from the hinge, back along the closed panel.
        length = door.collisions[0].shape.size[0]
        yaw = door.pose.yaw
        x = door.pose.xyz[0] + 0.5 * length * math.cos(yaw) - robot.pose.xyz[0]
        y = door.pose.xyz[1] + 0.5 * length * math.sin(yaw) - robot.pose.xyz[1]
        through = {"obj_00_x": x, "obj_00_y": y}
        assert not model.is_valid(state_with(model, **through)), f"{door.name} closed does not block"
        open_all = {o.name: math.pi / 2 for o in result.objects[1:] if o.is_movable}
        assert model.is_valid(state_with(model, **through, **open_all)), f"{door.name} open still blocks"


# -- end to end, through the planner -----------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("seed", [1, 2])
def test_generates_a_certified_puzzle(name, seed):
    from solver.pipelines.generation import generate_puzzle

    puzzle = generate_puzzle(name, seed)
    assert puzzle.certificate, "no solution certificate"
    assert puzzle.goal.is_reached(puzzle.planning_chain.state_dict(puzzle.certificate[-1]))
    assert any(a == "obj_01" for a, _ in puzzle.dependencies) or name == "rooms"
