"""One execution's state, its physics step and the gripper: what every part of a run shares.

:class:`RunState` holds both worlds (the simulation and the planning world), the clocks, counters
and the recording, checks every physics step (:meth:`RunState.on_step`: the grip rule, penetration,
unplanned contacts), and closes, opens and binds the gripper. Reaching a grasp
(:mod:`manipulation.grasp_approach`) and following an action (:mod:`manipulation.execution`)
build on it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pybullet as pb

from phyrogen_core.chain import KinematicChain
from phyrogen_core.export import LoadedPuzzle

from .execution_records import ExecutionError, ExecutionSettings, Recording, UnplannedContactError
from .following import TIME_STEP, command
from .placement import Placement, link_pose
from .scene import PUZZLE_CONTACT_TOLERANCE, TRACKING_TOLERANCE, World
from .transforms import inverse, matrix, quaternion

CLOSE_STEPS = 240
"""Physics steps (1 s) the fingers may take to close on a handle (full stroke at full speed: 0.28 s)."""
SQUEEZE_STEPS = 12
"""Steps both fingers must touch the handle, still, before the grasp holds."""
OPEN_STEPS = 240
"""Physics steps (1 s) the fingers are given to open after a release; still closed after them, the
robot does not drive (ExecutionError)."""
OPEN_STALL_STEPS = 24
"""Physics steps (0.1 s) after which opening fingers that have not left the handle and stand still
let it go (see :meth:`RunState.open_gripper`)."""
FINGER_TOUCH = 1e-3
"""Metres: a finger whose contact with the handle is closer than this touches it."""
GRIP_CONSTRAINT_FORCE = 5000.0
"""Newtons the grasp constraint may pull with (while both fingers hold the handle)."""


class RunState:
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

    # -- the gripper ---------------------------------------------------------
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
