"""The simulation and the planning world agree: the same joint values collide the same way in both.

They once did not: the simulation was built without robot self-collision, the planner with it. On
Move N Times 4 the follower folded the arm 2-5 cm into its own base, which the simulation allowed,
and the released robot was in collision for the planner, which could then plan no motion from it.
"""

from __future__ import annotations

import numpy as np
import pybullet as pb
import pytest

CONFIGURATIONS = 1500


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """A wall-heavy puzzle (Move N Times, fresh seed) scaled and written as the runner writes it."""
    from manipulation.placement import centred_placement, joint_value_scale, physical_scale, scale_chain
    from manipulation.robot import RobotSpec
    from manipulation.scene import write_scene_files
    from phyrogen_core.export import read_puzzle_dir, write_puzzle
    from solver.pipelines.generation import generate_puzzle

    out = tmp_path_factory.mktemp("worlds")
    loaded = read_puzzle_dir(write_puzzle(generate_puzzle("move_n_times", 731, {"n": 2}), out / "puzzles"))
    placement = centred_placement(loaded.chain, loaded.certificate, physical_scale("move_n_times"))
    chain = scale_chain(loaded.chain, placement.scale)
    states = np.asarray(loaded.certificate) * joint_value_scale(loaded.chain, placement.scale)
    (out / "scene").mkdir()
    return write_scene_files(out / "scene", chain, RobotSpec()), chain, placement, states


@pytest.fixture
def worlds(scene):
    from manipulation.scene import open_worlds

    files, chain, placement, _ = scene
    simulation, planner = open_worlds(files, chain, placement)
    yield simulation, planner
    simulation.close()
    planner.close()


def _random_configuration(rng: np.random.Generator, world) -> np.ndarray:
    """A base over or around the puzzle, any heading, any arm pose within limits."""
    reach = np.array(world.placement.half_extent) + 0.4
    base = [*rng.uniform(-reach, reach), rng.uniform(-np.pi, np.pi)]
    arm = rng.uniform(world.lower[3:], world.upper[3:])
    return np.array([*base, *arm])


def test_both_worlds_agree_on_collisions_clearance_and_self_contact(scene, worlds):
    _, _, _, states = scene
    simulation, planner = worlds
    rng = np.random.default_rng(20240611)
    self_touching = near_puzzle = 0
    for _ in range(CONFIGURATIONS):
        q = _random_configuration(rng, planner)
        puzzle = states[rng.integers(len(states))]
        answers = []
        for world in (simulation, planner):
            world.set_robot(q)
            world.set_puzzle(puzzle)
            answers.append((world.in_collision(), world.touches_itself(), round(world.clearance(0.05), 9)))
        assert answers[0] == answers[1], f"the worlds disagree at robot {q.round(3).tolist()}, puzzle {puzzle}"
        self_touching += answers[0][1]
        near_puzzle += answers[0][2] < 0.05
    # The sample reached both kinds of contact, so the comparison covered them.
    assert self_touching > 10 and near_puzzle > 10


def test_physics_keeps_and_reports_the_robot_touching_itself(worlds):
    """The arm folded into its base: the simulation reports the contact (the follower stops on it)."""
    simulation, planner = worlds
    rng = np.random.default_rng(7)
    for _ in range(CONFIGURATIONS):
        q = _random_configuration(rng, planner)
        planner.set_robot(q)
        if planner.in_collision() and planner.touches_itself():
            break
    else:
        pytest.fail("no self-touching configuration found")
    simulation.set_robot(q)
    pb.stepSimulation(physicsClientId=simulation.client)
    assert simulation.touches_itself()
