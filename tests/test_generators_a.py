"""Simple Slider, Grid World and Lockbox Random: parameters, layout, mechanism.

What every generator must guarantee (names, roles, handles, a free start,
determinism, documented parameters) is tested over the whole registry in
``test_registry.py``; this file tests what is particular to these three.
Most tests run the Maker with a validator that accepts every candidate (no
planner), so they check what the generators build; the mechanism tests sweep
joints through the exact collision model to show that every object really
blocks the one it was added for and that undoing the chain in reverse order
solves the puzzle. The end-to-end tests at the bottom use the real validator.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from maker_support import run

from phyrogen_core.geometry import ConvexPrism
from phyrogen_core.objects import Motion, PuzzleObject, build_chain
from phyrogen_core.registry import ParameterError, get_generator
from solver.collision.model import CollisionModel

SEEDS = (1, 2, 3, 4)
SWEEP_SAMPLES = 1201


class Sweeper:
    """Moves one joint at a time through the exact collision model."""

    def __init__(self, objects: tuple[PuzzleObject, ...]):
        self.chain = build_chain(objects)
        self.model = CollisionModel(self.chain)
        self.order = self.chain.joint_order
        self.state = np.zeros(len(self.order))

    def reach(self, joint: str, value: float) -> float:
        """How far ``joint`` gets from its current value towards ``value`` (others held)."""
        column = self.order.index(joint)
        values = np.linspace(self.state[column], value, SWEEP_SAMPLES)
        states = np.tile(self.state, (SWEEP_SAMPLES, 1))
        states[:, column] = values
        free = self.model.check(states)
        blocked = np.flatnonzero(~free)
        return float(values[-1] if blocked.size == 0 else values[max(blocked[0] - 1, 0)])

    def move(self, joint: str, value: float) -> bool:
        """Move ``joint`` to ``value`` if the way is free; True when it arrived."""
        arrived = abs(self.reach(joint, value) - value) < 1e-9
        if arrived:
            self.state[self.order.index(joint)] = value
        return arrived


def far_end(obj: PuzzleObject) -> float:
    lower, upper = obj.limits[0]
    return upper if abs(upper) >= abs(lower) else lower


def on_lattice(value: float, offset: float) -> bool:
    """Whether ``value`` is ``offset`` plus a whole number."""
    return abs((value - offset + 0.5) % 1.0 - 0.5) < 1e-9


def body(obj: PuzzleObject):
    return next(g for g in obj.collisions if g.name == "body")


# -- parameters ------------------------------------------------------------------
@pytest.mark.parametrize(("name", "seed", "overrides", "needle"), [
    ("simple_slider", 1, {"n_objects": -1}, "-1"),
    ("simple_slider", 99, {}, "100"),
    ("simple_slider", 1, {"n_objects": 100}, "100"),
    ("simple_slider", 1, {"gap": 0.0}, "gap"),
    ("simple_slider", 1, {"gap": 0.6}, "0.6"),
    ("grid_world", 1, {"n_objects": 0}, "n_objects"),
    ("grid_world", 1, {"n_objects": 100}, "100"),
    ("grid_world", 1, {"branching": -2}, "-2"),
    ("grid_world", 1, {"clearance": 0.05}, "0.05"),
    ("grid_world", 1, {"clearance": 0.5}, "clearance"),
    ("lockbox_random", 1, {"n_objects": 0}, "n_objects"),
    ("lockbox_random", 1, {"n_objects": 100}, "100"),
    ("lockbox_random", 1, {"max_radius": 0.5}, "0.5"),
])
def test_infeasible_parameters_are_refused_by_name(name, seed, overrides, needle):
    spec = get_generator(name)
    with pytest.raises(ParameterError, match=needle):
        spec.check(seed, spec.parse_params(overrides))


# -- structure -------------------------------------------------------------------
def test_simple_slider_has_seed_plus_one_sliders_unless_overridden():
    assert [len(run("simple_slider", seed).objects) for seed in SEEDS] == [2, 3, 4, 5]
    assert len(run("simple_slider", 2, n_objects=6).objects) == 6


def test_simple_slider_keeps_the_prototype_dimensions():
    for obj in run("simple_slider", 4).objects:
        assert body(obj).shape.size == pytest.approx((1.6, 0.2, 0.2))
        assert obj.motion is Motion.PRISMATIC and obj.limits == ((0.0, 1.0),)
        assert round(math.degrees(obj.pose.yaw)) % 90 == 0


def test_grid_world_boxes_sit_on_the_unit_grid():
    for seed in SEEDS:
        result = run("grid_world", seed)
        assert len(result.objects) == 5
        for obj in result.objects:
            cells = 2 if obj.motion is Motion.PRISMATIC else 3
            assert body(obj).shape.size == pytest.approx((cells - 0.1, 0.9, 0.9))
            x, y, _ = obj.pose.xyz
            # A two-cell slider is centred on a cell edge, a three-cell bar on a cell centre.
            along, across = (x, y) if abs(math.cos(obj.pose.yaw)) > 0.5 else (y, x)
            assert on_lattice(along, 0.0 if cells == 2 else 0.5)
            assert on_lattice(across, 0.5)
            if obj.motion is Motion.REVOLUTE:
                assert obj.limits in (((0.0, math.pi / 2),), ((-math.pi / 2, 0.0),))
            else:
                assert obj.limits == ((0.0, 1.0),)


def test_lockbox_alternates_sliders_and_slot_discs():
    for seed in SEEDS:
        result = run("lockbox_random", seed)
        assert len(result.objects) == 7
        for index, obj in enumerate(result.objects):
            if index % 2 == 0:
                assert obj.motion is Motion.PRISMATIC and obj.limits == ((0.0, 1.0),)
                assert body(obj).shape.size == pytest.approx((1.4, 0.2, 1.0))
            else:
                assert obj.motion is Motion.REVOLUTE
                assert obj.limits == ((-math.pi, math.pi),)
                shape = body(obj).shape
                assert isinstance(shape, ConvexPrism) and len(shape.pieces) == 3
                radius = max(math.hypot(*p) for piece in shape.pieces for p in piece)
                assert any(radius == pytest.approx(r) for r in (1.0, 1.5, 2.0, 2.5, 3.0))


# -- mechanism -------------------------------------------------------------------
@pytest.mark.parametrize("name", ("simple_slider", "grid_world"))
@pytest.mark.parametrize("seed", SEEDS)
def test_undoing_in_reverse_order_solves_and_every_object_is_needed(name, seed):
    objects = run(name, seed).objects
    solve = Sweeper(objects)
    for obj in reversed(objects):
        assert solve.move(obj.name, far_end(obj)), f"{obj.name} cannot reach its far end"
    # Each object, left at its start while everything added after it has moved away,
    # stops some earlier object on its way: none of them is superfluous.
    for k in range(1, len(objects)):
        sweep = Sweeper(objects)
        for later in objects[k + 1:][::-1]:
            assert sweep.move(later.name, far_end(later))
        stuck = [not sweep.move(obj.name, far_end(obj)) for obj in objects[:k][::-1]]
        assert any(stuck), f"{objects[k].name} blocks nothing"


@pytest.mark.parametrize("seed", SEEDS)
def test_simple_slider_each_slider_stops_the_previous_after_the_gap(seed):
    objects = run("simple_slider", seed).objects
    sweep = Sweeper(objects)
    for obj in objects[:-1]:
        assert sweep.reach(obj.name, 1.0) == pytest.approx(0.1, abs=2e-3)
    assert sweep.reach(objects[-1].name, 1.0) == pytest.approx(1.0)


@pytest.mark.parametrize("seed", SEEDS)
def test_lockbox_slots_lock_and_unlock_the_chain(seed):
    objects = run("lockbox_random", seed).objects
    sweep = Sweeper(objects)
    for index, obj in enumerate(objects[:-1]):
        if index % 2 == 0:
            # A slider runs into the rim of the disc ahead after 0.3 m.
            assert sweep.reach(obj.name, 1.0) == pytest.approx(0.3, abs=2e-3)
        else:
            # A disc with a slider in its slot only wiggles.
            assert abs(sweep.reach(obj.name, math.pi)) < 0.3
            assert abs(sweep.reach(obj.name, -math.pi)) < 0.3
    # From the last object back: slide out, turn the slot towards the previous slider
    # (the one turn among the quarter turns that lets it through), slide it in.
    for index in range(len(objects) - 1, -1, -1):
        obj = objects[index]
        if index % 2 == 0:
            assert sweep.move(obj.name, 1.0), f"{obj.name} cannot slide its full stroke"
            continue
        previous = objects[index - 1]
        opening = []
        for turn in (math.pi / 2, -math.pi / 2, math.pi, -math.pi):
            probe = Sweeper(objects)
            probe.state = sweep.state.copy()
            if probe.move(obj.name, turn) and probe.reach(previous.name, 1.0) == pytest.approx(1.0):
                opening.append(turn)
        assert opening, f"no quarter turn of {obj.name} lets {previous.name} through"
        assert sweep.move(obj.name, opening[0])
    assert sweep.state[sweep.order.index("obj_00")] == pytest.approx(1.0)


# -- end to end through the real validator ---------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize(("name", "overrides"), [
    ("simple_slider", {}),
    ("grid_world", {}),
    ("lockbox_random", {"n_objects": 3}),
])
def test_generate_puzzle_certifies_the_intended_chain(name, overrides):
    from solver.pipelines.generation import generate_puzzle
    from solver.planning.problem import verify_certificate

    puzzle = generate_puzzle(name, 1, overrides)
    assert verify_certificate(puzzle.planning_chain, puzzle.certificate, puzzle.goal) == []
    blockers = {blocker for blocker, _ in puzzle.dependencies}
    assert blockers == {o.name for o in puzzle.objects[1:]}
