"""Executing a puzzle's solution with the mobile iiwa, action by action, in physics.

For each action: pick the grasp point on the moving object, solve IK there
(with a look-ahead so the grasp is not singular a moment later) for a base on
floor it can drive to, plan the robot's motion (BIT*, or tuck the arm, drive
over the free floor and untuck), drive there, close the fingers (the object then
follows by their friction alone), and pull the object along its path by Jacobian control. When the monitor stops the
motion (joint flip, low manipulability, joint limit) the robot releases,
regrasps where it is well-conditioned for the object's next positions, and
goes on. At the end the target must be at its goal and the robot must never
have penetrated the puzzle.

The run is built in layers: :mod:`manipulation.run_state` (both worlds, the physics step's checks,
the gripper), :mod:`manipulation.grasp_approach` (reaching a grasp) and, here, following each
action and the attempts at a puzzle; the records they report in are :mod:`manipulation.execution_records`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from functools import partial
from pathlib import Path

import numpy as np
import pybullet as pb

from phyrogen_core.actions import Action, split_actions
from phyrogen_core.chain import JointType
from phyrogen_core.export import LoadedPuzzle, read_puzzle_dir
from solver.planning.problem import densify

from .execution_records import (
    ActionReport,
    AttemptReport,
    ExecutionError,
    ExecutionSettings,
    ManipulationReport,
    Recording,
    SceneSetup,
    UnplannedContactError,
)
from .floor import BORDER
from .following import Stop, command, follow, hold, time_trajectory
from .grasp import grasp_point, gripper_refusals
from .grasp_approach import GraspApproach
from .ik import GRASP_CLEARANCE
from .physics import with_masses
from .placement import Placement, centred_placement, joint_value_scale, physical_scale, scale_chain
from .reaching import seed_reaching
from .robot import ARM_REST
from .scene import Contact, open_worlds, temporary_folder, write_scene_files
from .solution import BenchmarkRun, Solution, candidate_solutions, solution_problems
from .source import solved_runs
from .transforms import inverse, matrix

PENETRATION_TOLERANCE = 0.002
"""Metres of robot-puzzle contact depth that still count as touching, not penetrating."""
SETTLE_STEPS = 60
"""Physics steps a released object is watched for drift before the next action."""
DRIFTED = "drifted after release"
"""An action's stop: the object was within the goal's tolerance of its end as the fingers let go, and
left it while it settled."""
NOT_THERE = "not at its end at release"
"""An action's stop: the follower's time (the path's and its settling window) ran out with the object
still outside the goal's tolerance of its end; letting go did not bring it there."""
REST_SPEED = 1e-3
"""Radians (or metres) per second: a puzzle joint slower than this is at rest."""
REST_STEPS = 2400
"""Physics steps (10 s) the robot waits, at most, for a released object to come to rest before it
plans its next grasp (a 80 kg Lockbox disc let go at 0.55 rad/s coasts about 7 s on its bearing)."""
HOME_CLEARANCE = 0.8
"""Metres between the base's centre at the start and the puzzle's floor area (on its -x side)."""

DEFAULT_SETTINGS = ExecutionSettings()
"""The settings :func:`execute_puzzle` runs with unless given others (frozen: shared safely)."""


class _Run(GraspApproach):
    """One execution (:class:`~manipulation.run_state.RunState`), following the actions of a solution
    (:meth:`execute`) with the grasps :class:`~manipulation.grasp_approach.GraspApproach` reaches."""

    def execute(self, action: Action) -> ActionReport:
        grasp = grasp_point(self.chain, action.object_name)
        link_index = self.sim.puzzle_link[grasp.link]
        states = densify(action.states * self.value_scale, self._check_steps())
        point = np.array([*grasp.point, 1.0])
        positions = np.array([(self.link_world(grasp.link, s) @ point)[:3] for s in states])
        revolute = [i for i, j in enumerate(self.chain.active_joints) if j.type is JointType.REVOLUTE]
        revolute = [i for i in revolute if i in action.columns]
        trajectory = time_trajectory(states, positions, revolute, self.settings.follow)
        columns = list(action.columns)
        end = states[-1]
        goal_tolerance = self.loaded.goal.tolerance * self.value_scale[columns]

        def within(tolerance: np.ndarray) -> bool:
            return bool(np.all(np.abs(self.sim.puzzle_state()[columns] - end[columns]) <= tolerance))

        object_done = partial(within, 0.4 * goal_tolerance)

        t, regrasps, stops = 0.0, 0, []
        failed_base: np.ndarray | None = None
        while True:
            self.plan_state = trajectory.state_at(t)
            # A grasp is planned on the object where it stands: one still moving (a heavy disc that
            # slipped from the fingers coasts on) would meet the open fingers somewhere else.
            self.wait_for_rest()
            self.grasp_here(grasp, trajectory, t, failed_base)
            started = time.perf_counter()
            if self.close_gripper(link_index):
                # The tool's pose on the link as the fingers hold it (closing may have nudged the object).
                tool_at_link = inverse(self.link_world(grasp.link, self.sim.puzzle_state())) @ matrix(
                    *self.sim.tool_pose())
                self.hold(link_index)
                result = follow(self.sim, trajectory, partial(self.tool_pose, grasp.link, tool_at_link), t,
                                self.settings.follow, self.on_step, object_done, self.sim.puzzle_state,
                                lambda up_to: self.sim.clearance(up_to, self.planned), self.sim.touches_itself,
                                lambda: self.grip is not None,
                                lambda now: setattr(self, "plan_state", trajectory.state_at(now)))
                # A grip that ended names its cause (a slip, with how far; a finger off the handle).
                stop = self.lost if result.stop is Stop.LOST_GRIP and self.lost else result.stop.value
                stopped_at, held = result.time, result.held
            else:
                stop, stopped_at, held = "the fingers did not close on the handle", t, None
            # Measured as the fingers let go: an object not at its end then never got there; one that
            # leaves it only afterwards drifted (the two causes had one label).
            there_at_release = within(goal_tolerance)
            self.open_gripper(held)
            self.execution += time.perf_counter() - started
            if stop in (Stop.DONE.value, Stop.WINDOW_ENDED.value):
                if self.settle_released(partial(within, goal_tolerance)):
                    break
                stop = DRIFTED if there_at_release else NOT_THERE
            stops.append(f"{stop} at t={stopped_at:.2f}s")
            regrasps += 1
            if regrasps > self.settings.max_regrasps_per_action:
                raise ExecutionError(f"moving {action.object_name}: more than "
                                     f"{self.settings.max_regrasps_per_action} regrasps ({'; '.join(stops)})")
            # A regrasp after the path's end still gets the follower's settling window to pull the
            # object back (from the end itself the follower had no time left, and a drifted object
            # was released where it lay, again and again).
            # The object may have moved on its own since the grip was lost (a heavy disc coasts on):
            # the path resumes where the object is once it rests, not where the grip was lost (the
            # follower pulled a disc that had coasted on back against it, again and again).
            self.wait_for_rest()
            now = self.sim.puzzle_state()[columns]
            scale = self._check_steps()[columns]
            gaps = np.max(np.abs(trajectory.states[:, columns] - now) / scale, axis=1)
            t = min(float(trajectory.times[int(np.argmin(gaps))]), trajectory.duration)
            failed_base = self.sim.robot_state()[:2]
        error = np.abs(self.sim.puzzle_state()[columns] - end[columns]) / self.value_scale[columns]
        return ActionReport(action.object_name, regrasps, tuple(stops), float(np.max(error)))

    def settle_released(self, in_place: Callable[[], bool]) -> bool:
        """Step the released object a while; whether it stayed within the goal tolerance.

        A small puzzle (Lockbox Random 2 did, when scenes were fitted to a square at scale
        0.056) can drift out of the tolerance after the release; the caller then regrasps and
        pushes it back."""
        hold(self.sim, self.sim.robot_state(), SETTLE_STEPS, self.on_step)
        return in_place()

    def wait_for_rest(self) -> None:
        """Hold the robot still until every puzzle joint is slower than :data:`REST_SPEED`, for at
        most :data:`REST_STEPS` steps."""
        q = self.sim.robot_state()
        for _ in range(REST_STEPS):
            speeds = [s[1] for s in pb.getJointStates(self.sim.puzzle, self.sim.puzzle_joints,
                                                       physicsClientId=self.sim.client)]
            if max(abs(v) for v in speeds) < REST_SPEED:
                return
            command(self.sim, q)
            pb.stepSimulation(physicsClientId=self.sim.client)
            self.on_step()

    def _check_steps(self) -> np.ndarray:
        # Fine enough that the grasp point moves a few millimetres between trajectory states.
        return np.array([0.004 if j.type is JointType.PRISMATIC else 0.01 for j in self.chain.active_joints])


def scene_placement(loaded: LoadedPuzzle, path: np.ndarray, settings: ExecutionSettings) -> Placement:
    """Where the puzzle stands at its scale (``settings.scale`` or its generator's physical scale)
    over ``path``; ValueError if it spans more floor than the base drives on."""
    generator = loaded.record.generator
    scale = settings.scale if settings.scale is not None else physical_scale(generator)
    placement = centred_placement(loaded.chain, path, scale)
    drive = settings.robot.base_range - BORDER
    if max(placement.half_extent) > drive:
        raise ValueError(f"puzzle {loaded.name!r} at scale {scale:g} spans "
                         f"{2 * max(placement.half_extent):.1f} m; the robot's base drives within {2 * drive:g} m "
                         "around it (choose a smaller scale)")
    return placement


def puzzle_identity(loaded: LoadedPuzzle, folder: Path) -> tuple[str, str, int]:
    """(generator, name, seed) from ``puzzle.json``: what the puzzle's random draws are seeded from."""
    return loaded.record.generator, loaded.name, loaded.record.seed


def execute_puzzle(folder: Path, settings: ExecutionSettings = DEFAULT_SETTINGS, gui: bool = False,
                   progress: Callable[[int, int], None] | None = None,
                   runs: Sequence[BenchmarkRun] = ()) -> tuple[ManipulationReport, Recording, SceneSetup]:
    """Execute the puzzle in ``folder``; returns the report, the recording and the scene setup.

    A puzzle with no best solution and no ``runs`` gets its ``runs`` first from
    ``settings.short_benchmark``, solved in memory (:func:`~manipulation.source.solved_runs`).
    The solutions of :func:`~manipulation.solution.candidate_solutions` (with the
    benchmark journal's ``runs``) are tried in order, each from the puzzle's start,
    until one succeeds; the recording and scene are those of the last one tried.
    Execution failures are reported (``success`` False, ``message``), not raised;
    a malformed puzzle folder raises.
    """
    folder = Path(folder)
    loaded = read_puzzle_dir(folder)
    generator, name, seed = puzzle_identity(loaded, folder)
    scale = settings.scale if settings.scale is not None else physical_scale(generator)
    refusals = gripper_refusals(scale_chain(loaded.chain, scale), settings.robot.gripper, GRASP_CLEARANCE)
    if refusals:
        # Before any simulation (and before a benchmark): no solution could be executed.
        message = "refused before simulation: the gripper cannot hold " + "; ".join(refusals)
        report = ManipulationReport(name, generator, seed, scale, "none", 0, 0, 0, 0.0, 0.0, 0.0, False, False,
                                    0.0, message)
        return report, Recording(), _unplaced_setup(loaded, scale, settings)
    started = time.perf_counter()
    if settings.short_benchmark is not None and not runs:
        runs = solved_runs(folder, loaded, settings.short_benchmark)
    benchmark_seconds = time.perf_counter() - started
    attempts: list[AttemptReport] = []
    recording, setup = Recording(), _unplaced_setup(loaded, scale, settings)  # when every solution is refused
    for solution in candidate_solutions(folder, loaded, runs):
        problems = solution_problems(loaded, solution) if settings.check_solutions else []
        if problems:
            # Refused before physics: a path our own model refutes is no test of the robot.
            attempts.append(AttemptReport(solution.label, scale, 0, 0, 0.0, 0.0, 0.0, False, False, 0.0,
                                          f"refused before simulation: {solution.source}: " + "; ".join(problems)))
            continue
        # Seeded per solution too: an attempt's outcome does not depend on the attempts before it.
        seed_reaching(generator, name, seed, solution.label)
        attempt, recording, setup = execute_solution(loaded, solution, settings, gui, progress)
        attempts.append(attempt)
        if attempt.success:
            break
    report = replace(ManipulationReport.of_attempts(name, generator, seed, attempts),
                     benchmark_seconds=benchmark_seconds)
    return report, recording, setup


def _unplaced_setup(loaded: LoadedPuzzle, scale: float, settings: ExecutionSettings) -> SceneSetup:
    """The scene of a puzzle no solution of which reached physics: scaled, not placed."""
    return SceneSetup(scale_chain(loaded.chain, scale), Placement(scale, (0.0, 0.0)), settings.robot)


def execute_solution(loaded: LoadedPuzzle, solution: Solution, settings: ExecutionSettings, gui: bool = False,
                     progress: Callable[[int, int], None] | None = None) -> tuple[AttemptReport, Recording,
                                                                                   SceneSetup]:
    """Execute one solution path of the puzzle from its start, in fresh worlds."""
    chain = loaded.chain
    factors = {name: cols for name, cols in chain.factors.items() if name != "goal"}
    actions = split_actions(solution.path, factors)
    placement = scene_placement(loaded, solution.path, settings)
    scaled = with_masses(scale_chain(chain, placement.scale), settings.material)
    value_scale = joint_value_scale(chain, placement.scale)
    setup = SceneSetup(scaled, placement, settings.robot)
    with temporary_folder() as tmp:
        files = write_scene_files(Path(tmp), scaled, settings.robot)
        sim, planner = open_worlds(files, scaled, placement, gui, settings.puzzle_self_collision, settings.robot,
                                   settings.material)
        run = _Run(loaded, scaled, placement, sim, planner, value_scale, settings)
        try:
            home = np.array([-placement.half_extent[0] - HOME_CLEARANCE, 0.0, 0.0, *ARM_REST])
            sim.set_robot(home)
            command(sim, home)
            run.command_fingers(0.0)
            run.record()
            reports: list[ActionReport] = []
            message = "ok"
            contact: Contact | None = None
            for index, action in enumerate(actions):
                run.action_index = index
                try:
                    reports.append(run.execute(action))
                except ExecutionError as exc:
                    message = f"action {index + 1}/{len(actions)} ({action.object_name}): {exc}"
                    contact = exc.contact if isinstance(exc, UnplannedContactError) else None
                    break
                if progress is not None:
                    progress(index + 1, len(actions))
            run.record()
            final = sim.puzzle_state() / value_scale
            at_goal = loaded.goal.is_reached(chain.state_dict(final))
            if message == "ok" and not at_goal:
                message = "the target did not reach its goal"
            if message == "ok" and run.max_penetration > PENETRATION_TOLERANCE:
                message = f"the robot penetrated the puzzle by {run.max_penetration * 1000:.1f} mm"
        finally:
            sim.close()
            planner.close()
    attempt = AttemptReport(solution.label, placement.scale, len(actions), sum(r.regrasps for r in reports),
                            run.planning, run.execution, run.steps / 240.0, message == "ok", at_goal,
                            run.max_penetration, message, tuple(reports), contact)
    return attempt, run.recording, setup
