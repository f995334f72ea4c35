"""Executing a puzzle's solution with the mobile iiwa, action by action, in physics.

For each action: pick the grasp point on the moving object, solve IK there
(with a look-ahead so the grasp is not singular a moment later) for a base on
floor it can drive to, plan the robot's motion (BIT*, or tuck the arm, drive
over the free floor and untuck), drive there, grasp (a fixed constraint), and pull
the object along its path by Jacobian control. When the monitor stops the
motion (joint flip, low manipulability, joint limit) the robot releases,
regrasps where it is well-conditioned for the object's next positions, and
goes on. At the end the target must be at its goal and the robot must never
have penetrated the puzzle.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path

import numpy as np
import pybullet as pb

from phyrogen_core.actions import Action, split_actions
from phyrogen_core.chain import JointType, KinematicChain
from phyrogen_core.export import LoadedPuzzle, read_puzzle_dir
from solver.planning.problem import densify

from .floor import BORDER, FloorMap, floor_map
from .following import TIME_STEP, FollowSettings, Stop, command, drive_along, follow, hold, time_trajectory
from .grasp import GraspPoint, grasp_point, gripper_refusals
from .ik import GRASP_CLEARANCE, IkSettings, best_grasp_configuration, solve_at
from .physics import PuzzleMaterial, with_masses
from .placement import Placement, centred_placement, joint_value_scale, link_pose, physical_scale, scale_chain
from .reaching import REACH_BUDGET, ReachingError, continuous_motion, plan_motion, seed_reaching
from .robot import ARM_REST, ARM_TUCKED, RobotSpec
from .scene import (
    COLLISION_MARGIN,
    PUZZLE_CONTACT_TOLERANCE,
    TRACKING_TOLERANCE,
    Contact,
    World,
    open_worlds,
    temporary_folder,
    write_scene_files,
)
from .solution import BenchmarkRun, Solution, candidate_solutions, solution_problems
from .source import ShortBenchmark, ensure_benchmark_solution
from .transforms import inverse, matrix, quaternion

PENETRATION_TOLERANCE = 0.002
"""Metres of robot-puzzle contact depth that still count as touching, not penetrating."""
LOOKAHEAD_SECONDS = (0.4, 0.8, 1.6)
"""How far ahead along the object's path a new grasp must stay well-conditioned."""
SETTLE_STEPS = 60
"""Physics steps a released object is watched for drift before the next action."""
LIFT_HEIGHTS = (0.03, 0.06, 0.1)
"""Metres the tool may rise straight up after a release, to clear the planning margin."""
REACH_TRIES = 3
"""Grasp configurations tried, best first, before the robot gives up reaching an object."""
DIRECT_REACH = 1.0
"""Metres: a base move up to this long is first tried as one BIT* search over all joints."""
CLOSE_STEPS = 240
"""Physics steps (1 s) the fingers may take to close on a handle (full stroke at full speed: 0.28 s)."""
SQUEEZE_STEPS = 12
"""Steps both fingers must touch the handle, still, before the grasp holds."""
OPEN_STEPS = 240
"""Physics steps (1 s) the fingers are given to open after a release; still closed after them, the
robot does not drive (ExecutionError)."""
OPEN_STALL_STEPS = 24
"""Physics steps (0.1 s) after which opening fingers that have not left the handle and stand still
let it go (see :meth:`_Run.open_gripper`)."""
FINGER_TOUCH = 1e-3
"""Metres: a finger whose contact with the handle is closer than this touches it."""
GRIP_CONSTRAINT_FORCE = 5000.0
"""Newtons the grasp constraint may pull with (while both fingers hold the handle)."""
APPROACH_HEIGHT = 0.05
"""Metres the tool rises straight up off a handle after a release, and comes straight down onto
the next (the fingertips start 3 cm above the knob)."""
APPROACH_LEAST = 0.025
"""Metres the tool must rise straight up at least (the fingertips 5 mm above the knob's top)."""
APPROACH_STEP = 0.001
"""Radians (or metres) per physics step, at most, of each joint while the tool rises or descends."""
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


class ExecutionError(RuntimeError):
    """The robot could not execute an action (no grasp, no motion, too many regrasps)."""


class UnplannedContactError(ExecutionError):
    """Physics found a contact the plan did not allow: the run stops at the first one."""

    def __init__(self, contact: Contact):
        super().__init__("unplanned contact: " + contact.describe())
        self.contact = contact


@dataclass(frozen=True)
class ExecutionSettings:
    scale: float | None = None
    """Scene metres per puzzle metre; None: the generator's physical scale
    (:func:`~manipulation.placement.physical_scale`)."""
    robot: RobotSpec = RobotSpec()
    follow: FollowSettings = FollowSettings()
    ik: IkSettings = IkSettings()
    reach_budget: int = REACH_BUDGET
    """Validity checks BIT* may spend on one motion (a count, not seconds: the same answer on any machine)."""
    max_regrasps_per_action: int = 12
    record_every: int = 8
    """Record the scene for frames and video every this many physics steps."""
    material: PuzzleMaterial = PuzzleMaterial()
    """Density and joint friction of the puzzle's pieces (masses from their volume)."""
    short_benchmark: ShortBenchmark | None = ShortBenchmark()
    """Run this benchmark first on a puzzle with no best solution and no benchmark runs given
    (:mod:`manipulation.source`); None: execute the certificate then."""
    puzzle_self_collision: bool = True
    """Whether the puzzle's objects and walls collide with each other (False: the scene as it was
    before they did, where an invalid path executed; kept as a negative control)."""


@dataclass(frozen=True)
class ActionReport:
    object_name: str
    regrasps: int
    stops: tuple[str, ...]
    final_error: float
    """Largest joint error (puzzle units) of the object at the end of the action."""


@dataclass(frozen=True)
class AttemptReport:
    """One solution executed from the puzzle's start, in fresh worlds."""

    solution: str
    """Which solution ran (:attr:`~manipulation.solution.Solution.label`)."""
    scale: float
    actions: int
    regrasps: int
    planning_seconds: float
    execution_seconds: float
    simulated_seconds: float
    success: bool
    target_at_goal: bool
    max_penetration: float
    message: str
    action_reports: tuple[ActionReport, ...] = ()
    contact: Contact | None = None
    """The unplanned contact that stopped the run, if one did."""


@dataclass(frozen=True)
class ManipulationReport:
    """The puzzle's outcome: the numbers of the solution that ran last (the one that succeeded, or
    the last one tried), with wall times summed over every attempt, and each attempt's report."""

    puzzle: str
    generator: str
    seed: int
    scale: float
    solution: str
    """Which solution the numbers are of: ``certificate`` or ``benchmark...: <planner> run <n>``."""
    solutions_tried: int
    actions: int
    regrasps: int
    planning_seconds: float
    execution_seconds: float
    simulated_seconds: float
    success: bool
    target_at_goal: bool
    max_penetration: float
    message: str
    attempts: tuple[AttemptReport, ...] = ()
    """Every solution tried, in order, each with its per-action reports."""
    contact: Contact | None = None
    """The unplanned contact that stopped the last attempt, if one did."""
    benchmark_seconds: float = 0.0
    """Wall time of the short benchmark run first for a solution (0: none ran)."""

    @classmethod
    def of_attempts(cls, puzzle: str, generator: str, seed: int,
                    attempts: Sequence[AttemptReport]) -> ManipulationReport:
        last = attempts[-1]
        message = last.message
        if not last.success and len(attempts) > 1:
            message = f"none of {len(attempts)} solutions executed; the last, {last.solution}: {message}"
        return cls(puzzle, generator, seed, last.scale, last.solution, len(attempts), last.actions, last.regrasps,
                   sum(a.planning_seconds for a in attempts), sum(a.execution_seconds for a in attempts),
                   last.simulated_seconds, last.success, last.target_at_goal, last.max_penetration, message,
                   tuple(attempts), last.contact)


@dataclass
class Recording:
    """Snapshots of the simulation: robot joints, puzzle joints (scene units), action index."""

    robot: list[np.ndarray] = field(default_factory=list)
    puzzle: list[np.ndarray] = field(default_factory=list)
    action: list[int] = field(default_factory=list)
    fingers: list[np.ndarray] = field(default_factory=list)
    """The gripper's two finger joints (0 open)."""
    holding: list[bool] = field(default_factory=list)
    """Whether both fingers held the handle (the object bound to the tool)."""


@dataclass(frozen=True)
class SceneSetup:
    """What a renderer needs to rebuild the scene: the scaled chain and its placement."""

    chain: KinematicChain
    placement: Placement
    robot: RobotSpec


class _Run:
    """The state of one execution: both worlds, clocks, counters and the recording."""

    def __init__(self, loaded: LoadedPuzzle, chain: KinematicChain, placement: Placement, sim: World,
                 planner: World, value_scale: np.ndarray, settings: ExecutionSettings):
        self.loaded, self.chain, self.placement = loaded, chain, placement
        self.sim, self.planner = sim, planner
        self.value_scale = value_scale
        self.settings = settings
        self.planning = 0.0
        self.execution = 0.0
        self.steps = 0
        self.max_penetration = 0.0
        self.recording = Recording()
        self.action_index = 0
        self.offset = np.eye(4)
        self.offset[:2, 3] = placement.offset
        self.planned: frozenset[tuple[int, int]] = frozenset()
        """(robot link, puzzle link) pairs whose contact the plan allows now (the fingers on the
        grasped object, from closing to opening)."""
        self.plan_state = sim.puzzle_state()
        """Where the path has the puzzle now (scene units): the state the grasp is pulled toward."""
        self.phase = "holding"
        """What the robot is doing (for reports): driving, closing, following, opening or holding."""
        self.grip: tuple[int, int] | None = None
        """(constraint, puzzle link) while both fingers hold the link; None otherwise."""

    # -- bookkeeping -------------------------------------------------------
    def on_step(self) -> None:
        self.steps += 1
        if self.grip is not None and not self.fingers_hold(self.grip[1]):
            # The rule: the object is bound to the tool only while both fingers touch it.
            self.release_constraint()
        self.max_penetration = max(self.max_penetration, self.sim.penetration(self.planned))
        if self.steps % self.settings.record_every == 0:
            self.record()
        contact = self.sim.unplanned_contact(self.planned, self.plan_touches)
        if contact is not None:
            self.record()
            raise UnplannedContactError(replace(contact, time=self.steps * TIME_STEP, phase=self.phase))

    def plan_touches(self, link_a: int, link_b: int) -> bool:
        """Whether the path, where it is now (:attr:`plan_state`), has the two puzzle links touching
        or within tracking tolerance, without overlapping (asked of the planning world)."""
        self.planner.set_puzzle(self.plan_state)
        distance = self.planner.distance_between(link_a, link_b, TRACKING_TOLERANCE)
        self.planner.set_puzzle(self.sim.puzzle_state())
        return -PUZZLE_CONTACT_TOLERANCE <= distance < TRACKING_TOLERANCE

    def record(self) -> None:
        self.recording.robot.append(self.sim.robot_state())
        self.recording.fingers.append(self.sim.finger_state())
        self.recording.holding.append(self.grip is not None)
        self.recording.puzzle.append(self.sim.puzzle_state())
        self.recording.action.append(self.action_index)

    def link_world(self, link: str, state: np.ndarray) -> np.ndarray:
        return self.offset @ link_pose(self.chain, link, state)

    def tool_pose(self, link: str, tool_at_link: np.ndarray, state: np.ndarray) -> np.ndarray:
        return self.link_world(link, state) @ tool_at_link

    # -- one action ----------------------------------------------------------
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
                self.attach(link_index, tool_at_link)
                result = follow(self.sim, trajectory, partial(self.tool_pose, grasp.link, tool_at_link), t,
                                self.settings.follow, self.on_step, object_done, self.sim.puzzle_state,
                                lambda up_to: self.sim.clearance(up_to, self.planned), self.sim.touches_itself,
                                lambda: self.grip is not None,
                                lambda now: setattr(self, "plan_state", trajectory.state_at(now)))
                stop = result.stop.value
                stopped_at = result.time
            else:
                stop, stopped_at = "the fingers did not close on the handle", t
            # Measured as the fingers let go: an object not at its end then never got there; one that
            # leaves it only afterwards drifted (the two causes had one label).
            there_at_release = within(goal_tolerance)
            self.open_gripper()
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

    def grasp_here(self, grasp: GraspPoint, trajectory, t: float, failed_base: np.ndarray | None) -> None:
        """Plan to and drive to a grasp of the object as it stands now, the fingers open around the
        handle."""
        started = time.perf_counter()
        now = self.sim.puzzle_state()
        self.planner.set_puzzle(now)
        link_now = self.link_world(grasp.link, now)
        point = (link_now @ np.array([*grasp.point, 1.0]))[:3]
        futures = [trajectory.state_at(t + dt) for dt in LOOKAHEAD_SECONDS]

        def lookahead(pose: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
            offset = inverse(link_now) @ pose
            return [(self.link_world(grasp.link, s) @ offset, s) for s in futures]

        link_yaw = float(np.arctan2(link_now[1, 0], link_now[0, 0]))

        def align(yaw: float) -> float:
            return grasp.tool_yaw(link_yaw, yaw)

        here = self.sim.robot_state()[:2]
        floor = floor_map(self.planner, self.placement.half_extent, here, self.settings.robot)

        def base_ok(xy: np.ndarray) -> bool:
            return floor.nearest_reachable(xy) is not None

        start = self.sim.robot_state()
        try:
            lift = self.lift_off(start)
        except ReachingError as exc:
            raise ExecutionError(f"reaching the grasp on {grasp.link}: {exc}") from None
        # A grasp whose base the robot cannot get to gives way to the next best, its base avoided.
        unreachable: list[np.ndarray] = []
        error: ReachingError | None = None
        for _ in range(REACH_TRIES):
            # Shorter look-aheads, then a smaller clearance, only when nothing better exists.
            failed = unreachable + ([] if failed_base is None else [failed_base])
            tiers = ((len(futures), failed, GRASP_CLEARANCE), (1, failed, GRASP_CLEARANCE),
                     (0, unreachable, GRASP_CLEARANCE), (0, unreachable, COLLISION_MARGIN))
            for count, avoid, clearance in tiers:
                solution = best_grasp_configuration(self.planner, point, lambda pose, n=count: lookahead(pose)[:n],
                                                    self.settings.ik, avoid, here, clearance, base_ok, align)
                if solution is not None and solution.score > 0:
                    break
            if solution is None and unreachable:
                raise ExecutionError(f"reaching the grasp on {grasp.link}: {error}; no other grasp there")
            if solution is None:
                raise ExecutionError(f"no collision-free IK solution at the grasp point of {grasp.link} "
                                     f"({np.round(point, 3).tolist()})")
            try:
                try:
                    descent = self.vertical(solution.q)[::-1]
                except ReachingError:
                    # No room to come straight down (an arm link meets the puzzle above the knob):
                    # the planned motion ends at the grasp itself, as it did before the approach.
                    descent = solution.q[None, :]
                path = self.reach(lift[-1], descent[0], floor)
                break
            except ReachingError as exc:
                error = exc
                unreachable.append(solution.q[:2])
        else:
            raise ExecutionError(f"reaching the grasp on {grasp.link} ({REACH_TRIES} grasps tried): {error}")
        self.planning += time.perf_counter() - started
        started = time.perf_counter()
        self.phase = "driving"
        # Straight up off the last handle, over to above this one, straight down around it: the
        # open fingers never sweep sideways past a knob (a planned motion passing beside it, tracked
        # by torque-limited motors, brushed it with a finger).
        drive_along(self.sim, lift, self.on_step, max_step=APPROACH_STEP)
        drive_along(self.sim, path, self.on_step)
        drive_along(self.sim, descent, self.on_step, max_step=APPROACH_STEP)
        self.phase = "holding"
        self.execution += time.perf_counter() - started

    def vertical(self, q: np.ndarray) -> np.ndarray:
        """A joint path from ``q`` raising the tool straight up by :data:`APPROACH_HEIGHT` (the base
        still), every state clear of the puzzle by the planning margin, in the planning world;
        ReachingError if IK or the margin fails on the way."""
        self.planner.set_robot(q)
        pose = matrix(*self.planner.tool_pose())
        states = [np.asarray(q, dtype=float)]
        count = int(np.ceil(APPROACH_HEIGHT / 0.005))
        for k in range(1, count + 1):
            above = pose.copy()
            above[2, 3] += APPROACH_HEIGHT * k / count
            # Damped Newton steps from the state below, not PyBullet's IK: its answer may lie on
            # another branch (a joint 1 rad away), and the joint-space motion between two such
            # states, which the robot drives, swept a finger 11 mm through the knob (Lockbox Random 1).
            nxt = solve_at(self.planner, above, states[-1], iterations=0, fixed_base=True)
            # Each state keeps the planning margin (as before); the motion between two, 5 mm
            # apart, must not touch (a released robot may start inside the margin).
            if nxt is None or not continuous_motion(self.planner, states[-1], nxt, margin=0.0):
                if APPROACH_HEIGHT * (k - 1) / count >= APPROACH_LEAST:
                    break  # high enough: the fingertips are off the knob
                raise ReachingError(f"the tool cannot rise {APPROACH_LEAST * 100:.1f} cm straight up "
                                    "from the grasp, clear of the puzzle")
            states.append(nxt)
        return np.array(states)

    def reach(self, start: np.ndarray, goal: np.ndarray, floor: FloorMap) -> np.ndarray:
        """A collision-free robot path from ``start`` to the grasp ``goal``: one BIT* search when
        the base moves little, else (or when that fails) tuck the arm, drive over the free floor,
        untuck."""
        budget, area = self.settings.reach_budget, self.placement.half_extent
        if np.linalg.norm(goal[:2] - start[:2]) <= DIRECT_REACH:
            try:
                return plan_motion(self.planner, start, goal, budget, area)
            except ReachingError:
                pass
        there = floor.nearest_reachable(goal[:2])
        if there is None:
            raise ReachingError("the base cannot drive from where it stands to the grasp")
        route = floor.route(floor.start_towards(there), there)
        tucked_here = np.array([*route[0], start[2], *ARM_TUCKED])
        drive = np.array([[*xy, start[2], *ARM_TUCKED] for xy in route] + [[*route[-1], goal[2], *ARM_TUCKED]])
        tuck = plan_motion(self.planner, start, tucked_here, budget, area)
        untuck = plan_motion(self.planner, drive[-1], goal, budget, area)
        return np.vstack([tuck, drive[1:], untuck[1:]])

    def lift_off(self, start: np.ndarray) -> np.ndarray:
        """The released robot's way off: the tool straight up by :data:`APPROACH_HEIGHT` (the open
        fingers rise off the handle they held); where that fails, a short straight lift clear of the
        planning margin when the robot is closer to the puzzle than it; else just ``start``."""
        try:
            return self.vertical(start)
        except ReachingError:
            pass
        self.planner.set_robot(start)
        if not self.planner.in_collision():
            return start[None, :]
        tool = matrix(*self.sim.tool_pose())
        for height in LIFT_HEIGHTS:
            above = tool.copy()
            above[2, 3] += height
            q = solve_at(self.planner, above, start)
            # The way up may begin inside the margin (that is why it is taken), but never touches.
            if q is not None and continuous_motion(self.planner, start, q, max_joint_step=None, margin=0.0):
                return np.array([start, q])
        raise ReachingError("the released robot is closer to the puzzle than the planning margin "
                            "and cannot lift its tool clear")

    def fingers_hold(self, link_index: int) -> bool:
        """Whether both fingers touch the puzzle link (a contact of the last physics step)."""
        return all(any(p[8] < FINGER_TOUCH for p in pb.getContactPoints(
            self.sim.robot, self.sim.puzzle, finger, link_index, physicsClientId=self.sim.client))
            for finger in self.sim.finger_joints)

    def close_gripper(self, link_index: int) -> bool:
        """Close the fingers on the link with the gripper's force, the arm held still; whether both
        touch it once they stop. Their contact with the link is planned from now until they open."""
        c, g = self.sim.client, self.settings.robot.gripper
        self.planned = frozenset((finger, link_index) for finger in self.sim.finger_joints)
        q = self.sim.robot_state()
        self.command_fingers(self.sim.finger_closed)
        self.phase = "closing"
        still = 0
        for _ in range(CLOSE_STEPS):
            command(self.sim, q)
            pb.stepSimulation(physicsClientId=c)
            self.on_step()
            still = still + 1 if self.finger_speed() < 0.2 * g.closing_speed and self.fingers_hold(link_index) else 0
            if still >= SQUEEZE_STEPS:
                self.phase = "following"
                return True
        self.phase = "holding"
        return False

    def command_fingers(self, target: float) -> None:
        g = self.settings.robot.gripper
        for finger in self.sim.finger_joints:
            pb.setJointMotorControl2(self.sim.robot, finger, pb.POSITION_CONTROL, targetPosition=target,
                                     force=g.grip_force, maxVelocity=g.closing_speed,
                                     physicsClientId=self.sim.client)

    def open_gripper(self) -> None:
        """Release: the fingers open; the constraint goes the step the first of them leaves the
        handle (:meth:`on_step`), or once they stall on it. (Removed before the fingers moved, the
        squeezed handle sprang out of them: a 0.9 kg Move N Times target left its goal tolerance at
        every release.) ExecutionError if they are not open after :data:`OPEN_STEPS`."""
        self.command_fingers(0.0)
        self.phase = "opening"
        q = self.sim.robot_state()
        g = self.settings.robot.gripper
        for step in range(OPEN_STEPS):
            if np.max(self.sim.finger_state()) < 1e-3:
                break
            if step >= OPEN_STALL_STEPS and self.grip is not None and self.finger_speed() < 0.2 * g.closing_speed:
                # A finger can stall on the handle it held: the handle, bound to the tool, cannot
                # give way, and PyBullet's contact then pushed the finger back in with the finger's
                # own force (86-90 N against 100 N, on Move N Times 83103 and 84204: the fingers
                # stayed closed and the robot drove off with them). Let go; they open at once.
                self.release_constraint()
            command(self.sim, q)
            pb.stepSimulation(physicsClientId=self.sim.client)
            self.on_step()
        self.release_constraint()
        opening = self.sim.finger_state()
        if np.max(opening) >= 1e-3:
            # Every plan assumes open fingers: driving with them closed would sweep them into the puzzle.
            raise ExecutionError(f"the fingers did not open ({np.max(opening) * 1000:.1f} mm of "
                                 f"{g.stroke / 2 * 1000:.1f} mm still closed after {OPEN_STEPS} steps)")
        self.planned = frozenset()
        self.phase = "holding"

    def finger_speed(self) -> float:
        return max(abs(s[1]) for s in pb.getJointStates(self.sim.robot, self.sim.finger_joints,
                                                         physicsClientId=self.sim.client))

    def release_constraint(self) -> None:
        if self.grip is not None:
            pb.removeConstraint(self.grip[0], physicsClientId=self.sim.client)
            self.grip = None

    def attach(self, link_index: int, tool_at_link: np.ndarray) -> int:
        """A fixed constraint between the tool and the link, at their current relative pose: made
        only once both fingers hold the link, removed as soon as either lets go (:meth:`on_step`)."""
        c = self.sim.client
        com = pb.getLinkState(self.sim.puzzle, link_index, computeForwardKinematics=True, physicsClientId=c)
        link_frame = matrix(com[4], com[5])
        com_frame = matrix(com[0], com[1])
        tool_in_com = inverse(com_frame) @ link_frame @ tool_at_link
        constraint = pb.createConstraint(self.sim.robot, self.sim.tool, self.sim.puzzle, link_index,
                                         pb.JOINT_FIXED, (0, 0, 0), (0, 0, 0), tuple(tool_in_com[:3, 3]),
                                         (0, 0, 0, 1), quaternion(tool_in_com), physicsClientId=c)
        pb.changeConstraint(constraint, maxForce=GRIP_CONSTRAINT_FORCE, physicsClientId=c)
        self.grip = (constraint, link_index)
        return constraint


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


def execute_puzzle(folder: Path, settings: ExecutionSettings = ExecutionSettings(), gui: bool = False,
                   progress: Callable[[int, int], None] | None = None,
                   runs: Sequence[BenchmarkRun] = ()) -> tuple[ManipulationReport, Recording, SceneSetup]:
    """Execute the puzzle in ``folder``; returns the report, the recording and the scene setup.

    A puzzle with no best solution and no ``runs`` gets one first from
    ``settings.short_benchmark`` (:func:`~manipulation.source.ensure_benchmark_solution`).
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
        ensure_benchmark_solution(folder, settings.short_benchmark)
        loaded = read_puzzle_dir(folder)
    benchmark_seconds = time.perf_counter() - started
    attempts: list[AttemptReport] = []
    recording, setup = Recording(), _unplaced_setup(loaded, scale, settings)  # when every solution is refused
    for solution in candidate_solutions(folder, loaded, runs):
        problems = solution_problems(loaded, solution)
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
