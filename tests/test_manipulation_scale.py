"""The robot's world at a physical scale: gripper-sized knobs, a floor the base drives on, and
puzzles that stay their size however many objects they hold."""

from __future__ import annotations

import random

import numpy as np
import pytest

from manipulation.floor import floor_map
from manipulation.placement import centred_placement, physical_scale, scale_chain
from manipulation.robot import RobotSpec
from manipulation.scene import World, write_scene_files
from phyrogen_core.generators.kit import fixed_box
from phyrogen_core.objects import build_chain
from phyrogen_core.registry import all_generators

GRIPPER_OPENING = (0.005, 0.085)
"""Metres: the widths a parallel gripper closes on (a Robotiq 2F-85 opens to 85 mm) and a
fingertip still holds."""
FINGER_DEPTH = 0.02
"""Metres of knob a fingertip pad needs to hold on to."""
SIZES = {"move_n_times": {"n": 1}, "simple_slider": {"n_objects": 2}, "rooms": {"n_rooms": 2, "doors": 1},
         "lockbox_random": {"n_objects": 3}, "grid_world": {"n_objects": 3}, "continuous_space": {"n_objects": 3}}
"""Small sizes (generation takes a second); the knob does not depend on the size."""


@pytest.mark.parametrize("generator", sorted(all_generators()))
def test_every_generators_knobs_are_a_size_a_parallel_gripper_holds(generator, tmp_path):
    from solver.pipelines.generation import generate_puzzle

    spec = all_generators()[generator]
    known = {f for f in spec.default_params().__dataclass_fields__}
    params = {k: v for k, v in SIZES.get(generator, {}).items() if k in known}
    seed = random.SystemRandom().randrange(10_000, 1_000_000)
    chain = scale_chain(generate_puzzle(generator, seed, params).chain, physical_scale(generator))
    knobs = [g.shape.size for link in chain.links for g in link.visuals if g.name == "knob"]
    assert knobs, f"{generator} seed {seed}: no knob"
    for width, depth, height in knobs:
        assert GRIPPER_OPENING[0] <= min(width, depth) and max(width, depth) <= GRIPPER_OPENING[1], (generator, seed)
        assert height >= FINGER_DEPTH, (generator, seed)


def _ring(side: float, gap: float):
    """Four walls 0.1 m thick around a ``side`` square, the -x wall with a ``gap`` wide doorway."""
    half, t, h = side / 2, 0.1, 0.5
    rest = (side - gap) / 2
    return build_chain([
        fixed_box("fixed_00_wall", 0.0, half, (side, t, h)),
        fixed_box("fixed_01_wall", 0.0, -half, (side, t, h)),
        fixed_box("fixed_02_wall", half, 0.0, (t, side, h)),
        fixed_box("fixed_03_wall", -half, half - rest / 2, (t, rest, h)),
        fixed_box("fixed_04_wall", -half, -half + rest / 2, (t, rest, h)),
    ], name="ring")


@pytest.mark.parametrize(("gap", "inside_reachable"), [(0.0, False), (1.0, True)])
def test_the_base_reaches_inside_a_walled_square_only_through_a_doorway_wide_enough(gap, inside_reachable, tmp_path):
    chain = _ring(3.0, gap)
    placement = centred_placement(chain, [[]], 1.0)
    world = World(write_scene_files(tmp_path, chain, RobotSpec()), chain, placement)
    try:
        floor = floor_map(world, placement.half_extent, np.array([-2.5, 0.0]), RobotSpec())
        assert floor.nearest_reachable(np.array([-2.5, 0.0])) is not None
        assert (floor.nearest_reachable(np.zeros(2), 0.1) is not None) == inside_reachable
        outside = floor.nearest_reachable(np.array([2.5, 0.0]), 0.1)
        assert outside is not None
        route = floor.route(floor.start_towards(outside), outside)
        # The drive goes around (or through the doorway), never through a wall: every stretch of it
        # is clear of the walls for the base turning on the spot.
        for a, b in zip(route, route[1:], strict=False):
            for t in np.linspace(0.0, 1.0, int(np.linalg.norm(b - a) / 0.02) + 2):
                assert world.floor_clear(a + t * (b - a), 0.3)
    finally:
        world.close()


def test_a_larger_puzzle_is_larger_in_the_scene_not_shrunk_to_fit(tmp_path):
    from manipulation.execution import ExecutionSettings, scene_placement
    from manipulation.placement import planar_bounds
    from phyrogen_core.export import read_puzzle_dir, write_puzzle
    from solver.pipelines.generation import generate_puzzle

    seed = random.SystemRandom().randrange(10_000, 1_000_000)
    areas = []
    for sliders in (2, 6):
        folder = write_puzzle(generate_puzzle("simple_slider", seed, {"n_objects": sliders}), tmp_path / str(sliders))
        loaded = read_puzzle_dir(folder)
        placement = scene_placement(loaded, loaded.certificate, ExecutionSettings())
        low, high = planar_bounds(loaded.chain, loaded.certificate)
        assert placement.scale == physical_scale("simple_slider"), seed
        assert np.allclose(placement.half_extent, placement.scale * (high - low) / 2), seed
        areas.append(np.prod(placement.half_extent))
    assert areas[1] > areas[0], (seed, areas)
