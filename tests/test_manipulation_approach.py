"""The robot's way onto a handle is checked as it is driven: the joint-space motion between two
states, not only the states.

A finger once brushed a Lockbox Random knob while the robot came straight down onto it: the
descent's states, each solved by PyBullet's IK 5 mm above the last, were all clear of the knob,
but one answer lay on another IK branch (a joint 1 rad from the state before), and the motion the
motors drove between the two swept the open finger 11 mm through the knob.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

SEED = 6247
"""A fresh Grid World seed no other test uses."""
FINE = 0.0005
"""Radians (or metres) of any joint between the states this test checks: far finer than the runner."""


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A runner's state on a fresh Grid World puzzle at its physical scale, at its start."""
    from manipulation.execution import ExecutionSettings, _Run, scene_placement
    from manipulation.physics import with_masses
    from manipulation.placement import joint_value_scale, scale_chain
    from manipulation.scene import open_worlds, write_scene_files
    from phyrogen_core.export import read_puzzle_dir, write_puzzle
    from solver.pipelines.generation import generate_puzzle

    out = tmp_path_factory.mktemp("approach")
    loaded = read_puzzle_dir(write_puzzle(generate_puzzle("grid_world", SEED, {}), out / "puzzles"))
    settings = ExecutionSettings(short_benchmark=None)
    placement = scene_placement(loaded, np.asarray(loaded.certificate), settings)
    chain = with_masses(scale_chain(loaded.chain, placement.scale), settings.material)
    (out / "scene").mkdir()
    files = write_scene_files(out / "scene", chain, settings.robot)
    sim, planner = open_worlds(files, chain, placement, spec=settings.robot, material=settings.material)
    planner.set_puzzle(np.asarray(loaded.certificate[0]) * joint_value_scale(loaded.chain, placement.scale))
    yield _Run(loaded, chain, placement, sim, planner, joint_value_scale(loaded.chain, placement.scale), settings)
    sim.close()
    planner.close()


def _grasps(run) -> list[np.ndarray]:
    """A grasp configuration (fingers open around the knob, the planning margin kept) on every
    object whose knob the arm reaches from outside the puzzle."""
    from manipulation.grasp import grasp_point
    from manipulation.ik import best_grasp_configuration

    state = run.planner.puzzle_state()
    found = []
    for name in sorted(n for n in run.chain.factors if n != "goal"):
        grasp = grasp_point(run.chain, name)
        link = run.link_world(grasp.link, state)
        point = (link @ np.array([*grasp.point, 1.0]))[:3]
        link_yaw = math.atan2(link[1, 0], link[0, 0])
        solution = best_grasp_configuration(run.planner, point,
                                            align=lambda yaw, g=grasp, y=link_yaw: g.tool_yaw(y, yaw))
        if solution is not None:
            found.append(solution.q)
    return found


def _least_clearance(world, start: np.ndarray, end: np.ndarray) -> float:
    delta = end - start
    count = max(1, math.ceil(float(np.max(np.abs(delta))) / FINE))
    least = math.inf
    for k in range(count + 1):
        world.set_robot(start + delta * (k / count))
        least = min(least, world.clearance(0.05))
    return least


def test_the_straight_approach_onto_every_reachable_knob_keeps_the_margin_all_the_way(run):
    from manipulation.reaching import STRAIGHT_JOINT_STEP
    from manipulation.scene import COLLISION_MARGIN

    grasps = _grasps(run)
    assert len(grasps) >= 3, "too few knobs within reach to say anything"
    for q in grasps:
        path = run.vertical(q)
        assert len(path) >= 6  # at least the 2.5 cm the tool must rise
        run.planner.set_robot(path[-1])
        top = run.planner.tool_pose()[0]
        run.planner.set_robot(path[0])
        bottom = run.planner.tool_pose()[0]
        assert np.linalg.norm((top - bottom)[:2]) < 1e-3 and top[2] - bottom[2] > 0.024
        for a, b in zip(path, path[1:], strict=False):
            assert np.max(np.abs(b - a)) <= STRAIGHT_JOINT_STEP
            run.planner.set_robot(b)
            assert run.planner.clearance(0.05) >= COLLISION_MARGIN
            # The motion between the states, as the motors drive it, not just the states.
            assert _least_clearance(run.planner, a, b) > 0.0


def test_a_motion_whose_ends_are_clear_but_which_sweeps_a_finger_through_the_knob_is_refused(run):
    """The negative control: both ends keep the planning margin (what a check of states alone
    sees), yet the open finger passes through the knob between them."""
    from manipulation.reaching import continuous_motion
    from manipulation.transforms import matrix

    refused = 0
    for q in _grasps(run):
        run.planner.set_robot(q)
        closing_axis = matrix(*run.planner.tool_pose())[:3, 1]  # the fingers close along the tool's y
        # The base slides the tool across the knob along the fingers' closing direction, past a finger.
        shifted = q.copy()
        shifted[:2] += 0.09 * closing_axis[:2] / np.linalg.norm(closing_axis[:2])
        ends_clear = []
        for end in (q, shifted):
            run.planner.set_robot(end)
            ends_clear.append(not run.planner.in_collision())
        if not all(ends_clear):
            continue
        assert _least_clearance(run.planner, q, shifted) < 0.0, "the finger was meant to pass through the knob"
        assert not continuous_motion(run.planner, q, shifted)
        refused += 1
    assert refused >= 1
