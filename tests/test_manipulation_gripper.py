"""The modelled gripper: handles it cannot hold are refused before any simulation, and the object
is held by the fingers' friction only while both touch its handle (opening them releases it)."""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np
import pytest

SEED = 5219
"""A fresh seed no other test uses."""


@pytest.fixture(scope="module")
def slider(tmp_path_factory):
    from phyrogen_core.export import write_puzzle
    from solver.pipelines.generation import generate_puzzle

    return write_puzzle(generate_puzzle("simple_slider", SEED, {"n_objects": 2}), tmp_path_factory.mktemp("gripper"))


@pytest.fixture
def no_simulation(monkeypatch):
    import manipulation.execution as execution

    def started(*args, **kwargs):
        raise AssertionError("a simulation (or the short benchmark) started")

    monkeypatch.setattr(execution, "execute_solution", started)
    monkeypatch.setattr(execution, "solved_runs", started)


@pytest.mark.parametrize(("scale", "why"), [(2.0, "wide"), (0.06, "tall")])
def test_a_handle_the_gripper_cannot_hold_is_refused_before_any_simulation(slider, scale, why, no_simulation,
                                                                           tmp_path):
    """At scale 2 the 5 cm knob is 100 mm wide (the fingers open to 85 mm); at 0.06 it is 12 mm
    tall, less than the pads' 20 mm and a margin."""
    from manipulation.execution import ExecutionSettings, execute_puzzle
    from manipulation.outputs import write_outputs

    report, recording, setup = execute_puzzle(slider, ExecutionSettings(scale=scale))
    assert not report.success and report.solutions_tried == 0
    assert report.message.startswith("refused before simulation: the gripper cannot hold")
    assert "obj_00" in report.message and "obj_01" in report.message and why in report.message
    out = write_outputs(tmp_path / "out", report, recording, setup, video=False)
    assert sorted(p.name for p in out.iterdir()) == ["report.json"]


def test_every_generators_handles_fit_the_gripper_at_its_physical_scale():
    """The control: at the scales the runs use, nothing is refused."""
    from manipulation.grasp import gripper_refusals
    from manipulation.ik import GRASP_CLEARANCE
    from manipulation.placement import physical_scale, scale_chain
    from manipulation.robot import GripperSpec
    from phyrogen_core.registry import all_generators
    from solver.pipelines.generation import generate_puzzle

    sizes = {"move_n_times": {"n": 1}, "simple_slider": {"n_objects": 2}, "rooms": {"n_rooms": 2, "doors": 1},
             "lockbox_random": {"n_objects": 3}, "grid_world": {"n_objects": 3}, "continuous_space": {"n_objects": 3}}
    for generator in sorted(all_generators()):
        known = set(all_generators()[generator].default_params().__dataclass_fields__)
        params = {k: v for k, v in sizes.get(generator, {}).items() if k in known}
        chain = scale_chain(generate_puzzle(generator, SEED, params).chain, physical_scale(generator))
        assert gripper_refusals(chain, GripperSpec(), GRASP_CLEARANCE) == [], generator


@contextmanager
def holding(slider, tmp_path, grip_force: float | None = None):
    """Worlds in which the robot has driven to the slider's target and closed its fingers on the
    handle (with ``grip_force`` per finger, else the datasheet's), the object held by their friction:
    yields (run, handle's link index)."""
    from dataclasses import replace

    from manipulation.execution import ExecutionSettings, _Run, scene_placement
    from manipulation.following import Trajectory, command
    from manipulation.grasp import grasp_point
    from manipulation.physics import with_masses
    from manipulation.placement import joint_value_scale, scale_chain
    from manipulation.reaching import seed_reaching
    from manipulation.robot import ARM_REST
    from manipulation.scene import open_worlds, write_scene_files
    from phyrogen_core.export import read_puzzle_dir

    loaded = read_puzzle_dir(slider)
    settings = ExecutionSettings(short_benchmark=None)
    if grip_force is not None:
        settings = replace(settings, robot=replace(settings.robot,
                                                   gripper=replace(settings.robot.gripper, grip_force=grip_force)))
    certificate = np.asarray(loaded.certificate, dtype=float)
    placement = scene_placement(loaded, certificate, settings)
    chain = with_masses(scale_chain(loaded.chain, placement.scale), settings.material)
    value_scale = joint_value_scale(loaded.chain, placement.scale)
    sim, planner = open_worlds(write_scene_files(tmp_path, chain, settings.robot), chain, placement)
    seed_reaching("simple_slider", loaded.name, SEED, "gripper test")
    try:
        run = _Run(loaded, chain, placement, sim, planner, value_scale, settings)
        home = np.array([-placement.half_extent[0] - 0.8, 0.0, 0.0, *ARM_REST])
        sim.set_robot(home)
        command(sim, home)
        grasp = grasp_point(chain, loaded.goal.target)
        link = sim.puzzle_link[grasp.link]
        still = Trajectory(np.array([0.0, 1.0]), np.vstack([sim.puzzle_state()] * 2))
        run.grasp_here(grasp, still, 0.0, None)
        assert run.grip is None and not run.fingers_hold(link)  # open fingers around the handle
        assert run.close_gripper(link) and run.fingers_hold(link)
        run.hold(link)
        yield run, link
    finally:
        sim.close()
        planner.close()


def test_the_object_is_held_only_while_both_fingers_touch_it(slider, tmp_path):
    """Close on the handle: both fingers touch, the grip holds. Hold: still held, nothing slipped.
    Open the fingers: they leave the handle within a few steps, and the tool then moves away without
    the object."""
    import pybullet as pb

    from manipulation.following import TIME_STEP, command

    with holding(slider, tmp_path) as (run, link):
        sim = run.sim
        q = sim.robot_state()
        for _ in range(60):  # held: the grip stays, the handle does not move in the fingers
            command(sim, q)
            pb.stepSimulation(physicsClientId=sim.client)
            run.on_step()
        assert run.grip is not None and run.lost is None and run.grip_lost(run.grip) is None
        run.open_gripper()
        assert run.grip is None and not any(run.fingers_touching(link))
        before, tool_before = sim.puzzle_state().copy(), np.asarray(sim.tool_pose()[0])
        lifted = q.copy()
        lifted[3 + 1] -= 0.2  # shoulder back: the tool rises and moves away
        for _ in range(int(1.0 / TIME_STEP)):
            command(sim, lifted)
            pb.stepSimulation(physicsClientId=sim.client)
        assert np.linalg.norm(np.asarray(sim.tool_pose()[0]) - tool_before) > 0.05
        assert np.allclose(sim.puzzle_state(), before, atol=1e-4), (before, sim.puzzle_state())


@pytest.mark.parametrize("grip_force", [None, 100.0])
def test_the_pads_press_with_the_commanded_grip_force(slider, tmp_path, grip_force):
    """Held still for 0.5 s, each pad presses on the handle with the force its finger is commanded
    with, within 10 %: the datasheet's 235 N (PyBullet's position motor stalled at 71-88 N there), and,
    the control, a lower command gives the lower squeeze."""
    import pybullet as pb

    from manipulation.following import command
    from manipulation.robot import GripperSpec

    commanded = GripperSpec().grip_force if grip_force is None else grip_force
    with holding(slider, tmp_path, grip_force) as (run, link):
        sim = run.sim
        q = sim.robot_state()
        pressed = []
        for _ in range(120):
            command(sim, q)
            pb.stepSimulation(physicsClientId=sim.client)
            run.on_step()
            pressed.append([sum(p[9] for p in pb.getContactPoints(sim.robot, sim.puzzle, finger, link,
                                                                  physicsClientId=sim.client))
                            for finger in sim.finger_joints])
        assert run.grip is not None and run.lost is None
        squeeze = np.mean(pressed[60:], axis=0)
        assert np.all(np.abs(squeeze - commanded) < 0.1 * commanded), (commanded, squeeze)


@pytest.mark.parametrize("glued", [False, True])
def test_fingers_that_cannot_open_stop_the_run_before_it_drives(slider, tmp_path, glued):
    """Every plan assumes open fingers. A finger held on the handle (here jammed in place by a
    constraint stronger than the finger's 235 N) makes the release fail with a named cause instead
    of the robot driving off with the finger closed; the control, with nothing glued, opens."""
    import pybullet as pb

    from manipulation.execution import ExecutionError

    with holding(slider, tmp_path) as (run, link):
        sim = run.sim
        if glued:
            finger = sim.finger_joints[0]
            # Jammed where it stands (the arm holds still while the fingers open).
            f = pb.getLinkState(sim.robot, finger, physicsClientId=sim.client)
            glue = pb.createConstraint(sim.robot, finger, -1, -1, pb.JOINT_FIXED, (0, 0, 0), (0, 0, 0), f[0],
                                       (0, 0, 0, 1), f[1], physicsClientId=sim.client)
            pb.changeConstraint(glue, maxForce=1000.0, physicsClientId=sim.client)
            with pytest.raises(ExecutionError, match="the fingers did not open"):
                run.open_gripper()
        else:
            run.open_gripper()
            assert np.max(sim.finger_state()) < 1e-3 and run.grip is None
