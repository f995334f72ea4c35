"""Manipulation: solution splitting, scaling, grasp points, the robot model, and one puzzle end to end."""

from __future__ import annotations

import json
import math

import numpy as np
import pybullet as pb
import pytest

from manipulation.grasp import grasp_point
from manipulation.linalg import damped_least_squares, manipulability
from manipulation.placement import centred_placement, joint_value_scale, link_pose, scale_chain
from manipulation.robot import ROBOT_JOINTS, RobotSpec, mobile_iiwa_urdf
from manipulation.solution import load_solution
from phyrogen_core.actions import count_actions, split_actions
from phyrogen_core.chain import Geometry, JointType, KinematicChain, Role
from phyrogen_core.folder_layout import BEST_SOLUTION
from phyrogen_core.geometry import Box, Pose
from phyrogen_core.objects import Motion, PuzzleObject, build_chain


def _two_sliders() -> KinematicChain:
    body = Geometry(Box((1.0, 0.2, 0.2)))
    knob = Geometry(Box((0.05, 0.05, 0.2)), Pose((0.1, 0.0, 0.3)), name="knob")
    return build_chain([
        PuzzleObject("obj_00", Motion.PRISMATIC, Pose.planar(0, 0, 0.1), (body, knob), (body,), Role.TARGET,
                     ((0.0, 1.0),)),
        PuzzleObject("obj_01", Motion.SE2, Pose.planar(3, 0, 0.1), (body,), (body,), Role.BLOCKER,
                     ((-1.0, 1.0), (-1.0, 1.0), (-3.0, 3.0))),
    ])


def test_split_actions_moves_one_object_per_action_and_matches_the_action_count():
    chain = _two_sliders()
    path = np.array([[0, 0, 0, 0], [0.5, 0.2, 0.1, 0.0], [0.5, 0.4, 0.1, 0.3], [1.0, 0.4, 0.1, 0.3]], dtype=float)
    actions = split_actions(path, chain.factors)
    assert len(actions) == count_actions(path, chain.factors) == 3
    assert [a.object_name for a in actions] == ["obj_00", "obj_01", "obj_00"]
    for action in actions:
        others = [i for i in range(4) if i not in action.columns]
        assert np.allclose(action.states[:, others], action.states[0, others])
    assert np.allclose(actions[0].start, path[0]) and np.allclose(actions[-1].end, path[-1])
    for before, after in zip(actions, actions[1:], strict=False):
        assert np.allclose(before.end, after.start)
        assert before.object_name != after.object_name


def test_solution_file_is_preferred_and_reordered_by_joint_name(tmp_path):
    order = ("a", "b")
    certificate = ((0.0, 0.0), (1.0, 1.0))
    assert load_solution(tmp_path, order, certificate).source == "certificate"
    (tmp_path / BEST_SOLUTION).parent.mkdir()
    (tmp_path / BEST_SOLUTION).write_text(json.dumps({"joint_order": ["b", "a"], "path": [[0, 0], [2, 1]]}))
    solution = load_solution(tmp_path, order, certificate)
    assert solution.source != "certificate"
    assert solution.path.tolist() == [[0.0, 0.0], [1.0, 2.0]]
    (tmp_path / BEST_SOLUTION).write_text(json.dumps({"joint_order": ["b", "c"], "path": [[0, 0], [2, 1]]}))
    with pytest.raises(ValueError, match="does not match"):
        load_solution(tmp_path, order, certificate)


def test_scaled_chain_moves_points_by_the_scale():
    chain = _two_sliders()
    state = np.array([0.7, 0.3, -0.2, 0.5])
    placement = centred_placement(chain, [np.zeros(4), state], 0.37)
    scaled = scale_chain(chain, placement.scale)
    scaled_state = state * joint_value_scale(chain, placement.scale)
    assert [j.type for j in scaled.active_joints].count(JointType.PRISMATIC) == 3
    for link in ("obj_00", "obj_01"):
        original = chain.link_transforms(state)[link]
        moved = link_pose(scaled, link, scaled_state)
        assert np.allclose(moved[:3, 3], placement.scale * original[:3, 3])
        assert np.allclose(moved[:3, :3], original[:3, :3])


def test_grasp_point_is_the_top_of_the_knob_else_the_top_of_the_body():
    chain = _two_sliders()
    knob = grasp_point(chain, "obj_00")
    assert knob.on_knob and knob.link == "obj_00" and np.allclose(knob.point, (0.1, 0.0, 0.4))
    body = grasp_point(chain, "obj_01")
    assert not body.on_knob and np.allclose(body.point, (0.0, 0.0, 0.1))
    with pytest.raises(ValueError, match="obj_99"):
        grasp_point(chain, "obj_99")


def test_damped_least_squares_matches_the_closed_form():
    rng = np.random.default_rng(0)
    jacobian, twist = rng.normal(size=(6, 10)), rng.normal(size=6)
    weights = np.array([8.0] * 3 + [1.0] * 7)
    w_inv = np.diag(1 / weights)
    expected = w_inv @ jacobian.T @ np.linalg.solve(jacobian @ w_inv @ jacobian.T + 0.02**2 * np.eye(6), twist)
    assert np.allclose(damped_least_squares(jacobian, weights, 0.02, twist), expected)
    arm = np.ascontiguousarray(jacobian[:, 3:])
    assert manipulability(arm) == pytest.approx(np.sqrt(np.linalg.det(arm @ arm.T)))
    arm[5] = arm[4]  # two equal rows: singular
    assert manipulability(arm) == pytest.approx(0.0, abs=1e-6)


def test_mobile_iiwa_is_one_fixed_base_body_with_ten_joints_and_a_two_finger_gripper(tmp_path):
    from manipulation.robot import FINGER_JOINTS

    path = tmp_path / "robot.urdf"
    spec = RobotSpec()
    path.write_text(mobile_iiwa_urdf(spec))
    client = pb.connect(pb.DIRECT)
    try:
        robot = pb.loadURDF(str(path), useFixedBase=True, physicsClientId=client)
        count = pb.getNumJoints(robot, physicsClientId=client)
        infos = [pb.getJointInfo(robot, j, physicsClientId=client) for j in range(count)]
        movable = [i[1].decode() for i in infos if i[2] != pb.JOINT_FIXED]
        assert sorted(movable) == sorted(ROBOT_JOINTS + FINGER_JOINTS)
        assert [m for m in movable if m in ROBOT_JOINTS] == list(ROBOT_JOINTS)
        fingers = [i for i in infos if i[1].decode() in FINGER_JOINTS]
        assert all(i[8] == 0.0 and i[9] == pytest.approx(spec.gripper.stroke / 2) for i in fingers)
        tool = next(j for j, i in enumerate(infos) if i[12].decode() == "tool")
        linear, _ = pb.calculateJacobian(robot, tool, (0, 0, 0), [0.0] * 12, [0.0] * 12, [0.0] * 12,
                                         physicsClientId=client)
        assert np.asarray(linear).shape == (3, 12)
        # The housing sits on the flange face, not floating off it: its top touches link 7's mesh end.
        housing = next(j for j, i in enumerate(infos) if i[12].decode() == "gripper")
        pb.resetJointStatesMultiDof(robot, [j for j, i in enumerate(infos) if i[2] != pb.JOINT_FIXED],
                                    [[0.0]] * 12, physicsClientId=client)
        flange = np.asarray(pb.getLinkState(robot, housing - 1 if infos[housing][16] == housing - 1
                                            else infos[housing][16], physicsClientId=client)[4])
        top = np.asarray(pb.getLinkState(robot, housing, physicsClientId=client)[4])
        assert np.linalg.norm(top - flange) == pytest.approx(0.045, abs=1e-6)
    finally:
        pb.disconnect(client)


@pytest.mark.slow
def test_robot_executes_a_simple_slider_end_to_end(tmp_path):
    from manipulation.execution import execute_puzzle
    from manipulation.outputs import write_outputs
    from phyrogen_core.export import write_puzzle
    from phyrogen_core.seeding import stable_seed
    from solver.pipelines.generation import generate_puzzle
    from solver.planning.ompl_setup import seed_ompl

    puzzle = generate_puzzle("simple_slider", 1)
    folder = write_puzzle(puzzle, tmp_path / "puzzles")
    seed_ompl(stable_seed("ompl", "manipulation-test", 1))
    report, recording, setup = execute_puzzle(folder)
    assert report.success, report.message
    assert report.target_at_goal
    assert report.max_penetration <= 0.002
    out = write_outputs(tmp_path / "out", report, recording, setup, video=False)
    # The default solution source: a run of the in-memory LA-RRT solve (the folder had no best file).
    assert report.solution.startswith("benchmark: LA-RRT run "), report.solution
    assert report.actions == count_actions(puzzle.certificate, puzzle.planning_chain.factors)
    expected = [f"frame_{i}.png" for i in range(1, 5)] + [f"grip_{i}.png" for i in range(1, report.actions + 1)]
    assert sorted(p.name for p in (out / "frames").iterdir()) == sorted(expected)
    assert json.loads((out / "report.json").read_text())["success"] is True


def test_ik_reaches_the_pose_exactly_and_keeps_a_fixed_base(tmp_path):
    from manipulation.ik import solve_at
    from manipulation.placement import Placement
    from manipulation.robot import ARM_REST
    from manipulation.scene import World, write_scene_files
    from manipulation.transforms import matrix, tool_down

    chain = _two_sliders()
    world = World(write_scene_files(tmp_path, chain, RobotSpec()), chain, Placement(1.0, (0.0, 0.0)))
    try:
        seed = np.array([-2.0, 1.0, 0.0, *ARM_REST])
        target = tool_down((-1.4, 1.05, 0.25), math.pi)
        for fixed in (False, True):
            q = solve_at(world, target, seed, fixed_base=fixed)
            assert q is not None
            world.set_robot(q)
            reached = matrix(*world.tool_pose())
            assert np.linalg.norm(reached[:3, 3] - target[:3, 3]) < 5e-5
            if fixed:
                assert np.allclose(q[:3], seed[:3], atol=1e-5)
        # Out of the arm's reach with the base held: no answer rather than a wrong one.
        assert solve_at(world, tool_down((0.0, 1.0, 0.25), math.pi), seed, fixed_base=True) is None
    finally:
        world.close()
