"""The puzzle's objects collide in the simulation: an invalid path (the target straight to its goal,
its blockers left in place) stops at a named contact, and executes only in a scene built without
PyBullet's self-collision for the puzzle (the scene as it was before: a negative control)."""

from __future__ import annotations

import numpy as np
import pytest

CASES = [("simple_slider", 5117, {"n_objects": 2}), ("grid_world", 5123, {})]
"""Fresh seeds no other test uses."""


@pytest.fixture(scope="module", params=CASES, ids=[c[0] for c in CASES])
def invalid(request, tmp_path_factory):
    """(loaded puzzle, invalid path): the target moved straight from the start to its goal, every
    other object where it starts."""
    from phyrogen_core.export import read_puzzle_dir, write_puzzle
    from solver.collision.model import CollisionModel
    from solver.pipelines.generation import generate_puzzle
    from solver.planning.problem import densify

    generator, seed, params = request.param
    puzzle = generate_puzzle(generator, seed, params)
    loaded = read_puzzle_dir(write_puzzle(puzzle, tmp_path_factory.mktemp(generator)))
    start = np.asarray(loaded.certificate[0], dtype=float)
    end = start.copy()
    columns = loaded.chain.factors[loaded.goal.target]
    end[columns] = np.asarray(loaded.certificate[-1], dtype=float)[columns]
    path = np.array([start, end])
    # The precondition: our own collision model says the straight move hits something.
    model = CollisionModel(puzzle.planning_chain)
    states = densify(path, np.full(len(start), 0.004))
    assert not all(model.is_valid(s) for s in states), f"{generator} {seed}: the straight move is free"
    return generator, seed, loaded, path


def _execute(loaded, path, self_collision: bool):
    from manipulation.execution import ExecutionSettings, execute_solution
    from manipulation.reaching import seed_reaching
    from manipulation.solution import Solution

    seed_reaching(loaded.record.generator, loaded.name, loaded.record.seed, "invalid")
    attempt, _, _ = execute_solution(loaded, Solution(path, "test", "invalid path"),
                                     ExecutionSettings(puzzle_self_collision=self_collision))
    return attempt


def test_an_invalid_path_stops_at_a_named_contact_between_the_target_and_a_blocker(invalid):
    generator, seed, loaded, path = invalid
    attempt = _execute(loaded, path, self_collision=True)
    assert not attempt.success and not attempt.target_at_goal, (generator, seed)
    contact = attempt.contact
    assert contact is not None, attempt.message
    assert (contact.body_a, contact.body_b) == ("puzzle", "puzzle")
    target = loaded.goal.target
    links = {contact.link_a, contact.link_b}
    assert target in links and len(links - {target}) == 1, contact
    blocker = (links - {target}).pop()
    assert loaded.chain.link(blocker).object_name != target
    assert contact.time > 0 and (contact.depth > 0 or contact.force > 0)
    assert "unplanned contact" in attempt.message and blocker in attempt.message


def test_without_the_puzzles_self_collision_the_invalid_path_executes(invalid):
    """The negative control: with the flag off, nothing stops the target going through its blocker."""
    generator, seed, loaded, path = invalid
    attempt = _execute(loaded, path, self_collision=False)
    assert attempt.success and attempt.contact is None, (generator, seed, attempt.message)


def test_walls_that_meet_report_no_contact_but_a_moving_object_against_one_does(tmp_path):
    """PyBullet checks every pair of links of a self-colliding body but parent and child: the pairs
    that cannot move apart (the scenery's walls, which meet in corners) are switched off."""
    import pybullet as pb

    from manipulation.placement import Placement
    from manipulation.robot import ARM_REST, RobotSpec
    from manipulation.scene import World, rigid_groups, write_scene_files
    from solver.pipelines.generation import generate_puzzle

    chain = generate_puzzle("move_n_times", 5137, {"n": 2}).chain
    groups = rigid_groups(chain)
    assert sum(1 for g in groups.values() if g == "scenery") >= 3
    world = World(write_scene_files(tmp_path, chain, RobotSpec()), chain, Placement(1.0, (0.0, 0.0)))
    try:
        world.set_robot([-5.0, 0.0, 0.0, *ARM_REST])  # out of the puzzle's way
        pb.stepSimulation(physicsClientId=world.client)
        pairs = {frozenset((world.puzzle_link_name[p[3]], world.puzzle_link_name[p[4]]))
                 for p in pb.getContactPoints(world.puzzle, world.puzzle, physicsClientId=world.client)}
        assert not any(all(groups[name] == "scenery" for name in pair) for pair in pairs), pairs
        assert world.unplanned_contact() is None
        # The target set half into its pocket's east wall: a contact, deep and named.
        assert chain.joint_order[:3] == ("obj_00_x", "obj_00_y", "obj_00_yaw")
        world.set_puzzle([0.5, 0.0, 0.0, 0.0])
        pb.stepSimulation(physicsClientId=world.client)
        contact = world.unplanned_contact()
        assert contact is not None and contact.depth > 0.05, contact
        assert "obj_00" in (contact.link_a, contact.link_b)
        assert groups[({contact.link_a, contact.link_b} - {"obj_00"}).pop()] == "scenery"
    finally:
        world.close()
