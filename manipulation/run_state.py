"""One execution's state, its physics step and the gripper: what every part of a run shares.

:class:`RunState` holds both worlds (the simulation and the planning world), the clocks, counters
and the recording, checks every physics step (:meth:`RunState.on_step`: the grip, penetration, unplanned contacts),
and closes and opens the gripper, whose fingers hold an object by their friction alone: the handle is
watched in the fingers and a slip is named. Reaching a grasp
(:mod:`manipulation.grasp_approach`) and following an action (:mod:`manipulation.execution`)
build on it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pybullet as pb

from phyrogen_core.chain import KinematicChain
from phyrogen_core.export import LoadedPuzzle

from .execution_records import ExecutionError, ExecutionSettings, Recording, UnplannedContactError
from .following import TIME_STEP, command, lift_tool
from .placement import Placement, link_pose
from .scene import PUZZLE_CONTACT_TOLERANCE, TRACKING_TOLERANCE, World
from .transforms import inverse, matrix, rotation_error

CLOSE_STEPS = 240
"""Physics steps (1 s) the fingers may take to close on a handle (full stroke at full speed: 0.28 s)."""
SQUEEZE_STEPS = 12
"""Steps both fingers must touch the handle, still, before the grasp holds."""
OPEN_STEPS = 240
"""Physics steps (1 s) the fingers are given to open after a release; still closed after them, the
robot does not drive (ExecutionError)."""
OPEN_STALL_STEPS = 24
"""Physics steps (0.1 s) after the slow opening after which fingers still on the handle and standing
still are lifted off it (see :meth:`RunState.open_gripper`)."""
FINGER_TOUCH = 1e-3
"""Metres: a finger whose contact with the handle is closer than this touches it."""
LOST_STEPS = 12
"""Physics steps (0.05 s) a finger may go without contact on the held handle before the grip is lost."""
SLIP_DISTANCE = 0.005
"""Metres the grasp point may move on the handle (tool point in the handle's frame, from where the
fingers closed) before the grasp counts as slipped."""
SLIP_ANGLE = 0.05
"""Radians the handle may turn in the fingers before the grasp counts as slipped."""
OPEN_SLOW_SPEED = 0.02
"""Metres per second the fingers open at until both have left the handle (the 2F-85's slowest
speed): at full speed the last pad to leave a light handle kicked it off its goal."""


LINKAGE_STIFFNESS = 2000.0
"""Newtons per metre between the two fingers' travels while they squeeze (:meth:`RunState.squeeze`):
the stiffest an explicit force on 50 g fingers stays stable with at 240 steps a second."""
LINKAGE_DAMPING = 2.0
"""Newton seconds per metre between the two fingers' speeds while they squeeze."""
SOLVER_ITERATIONS = 50
"""PyBullet's default solver iterations a step, while the fingers do not squeeze."""
SQUEEZE_SOLVER_ITERATIONS = 200
"""Solver iterations a step while they squeeze: with 50, each finger's motor, solved with the pads'
contacts, stalled at 71-88 N of its 235 N limit on a blocked handle (87 N whether 235 N or 100 N was
commanded); with 200 it reaches its limit, and the pads press with it."""

OPEN_SLOW_STEPS = 72
"""Physics steps (0.3 s, 6 mm of each finger) the slow opening lasts at most: a handle pressed on one
pad follows it as it opens."""


LIFT_MARGIN = 0.01
"""Metres the pads rise above the handle's top when fingers stalled on it are lifted off."""
OPEN_LIFT_SPEED = 0.1
"""Metres per second of that lift."""
RELEASE_LIFT_SPEED = 0.2
"""Metres per second the tool rises as the fingers begin to open on a handle: ten times their slow
opening, so that a pad still touching the handle slides up it and its friction pulls the handle up
(which the puzzle's planar joints take) and sideways with at most a tenth of itself (0.05 N of the
0.5 N contact measured, against a Move N Times target's joint friction of 0.44 N)."""


@dataclass(frozen=True)
class Grip:
    """An object held by the fingers' friction: the handle's link and where the tool held it as the
    fingers closed (the tool's pose in the link's frame)."""

    link: int
    tool_at_link: np.ndarray


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
        self.grip: Grip | None = None
        """The held handle while both fingers hold it and it has not slipped; None otherwise."""
        self.lost: str | None = None
        """Why the last grip ended while following (a slip, a finger off the handle); None while held."""
        self.off_handle = 0
        """Physics steps in a row a finger has not touched the held handle."""
        self.squeezing: int | None = None
        """The puzzle link the closed fingers press on with the gripper's force (:meth:`squeeze`), or None."""

    def on_step(self) -> None:
        self.steps += 1
        if self.squeezing is not None:
            self.squeeze(self.squeezing)
        if self.grip is not None and self.phase == "following":
            self.lost = self.grip_lost(self.grip)
            if self.lost is not None:
                self.grip = None
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
    def fingers_touching(self, link_index: int) -> list[bool]:
        """Per finger, whether it touches the puzzle link (a contact of the last physics step)."""
        return [any(p[8] < FINGER_TOUCH for p in pb.getContactPoints(
            self.sim.robot, self.sim.puzzle, finger, link_index, physicsClientId=self.sim.client))
            for finger in self.sim.finger_joints]

    def fingers_hold(self, link_index: int) -> bool:
        """Whether both fingers touch the puzzle link."""
        return all(self.fingers_touching(link_index))

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
                self.squeezing = link_index
                pb.setPhysicsEngineParameter(numSolverIterations=SQUEEZE_SOLVER_ITERATIONS, physicsClientId=c)
                self.squeeze(link_index)
                return True
        self.phase = "holding"
        return False

    def squeeze(self, link_index: int) -> None:
        """While the closed fingers press on the link: each finger's motor pushes with the gripper's
        force (with :data:`SQUEEZE_SOLVER_ITERATIONS` it reaches it), and the 2F-85's linkage, which
        moves both fingers alike, is stood for by a spring and damper on their difference
        (:data:`LINKAGE_STIFFNESS`, :data:`LINKAGE_DAMPING`), applied as opposite joint forces for the
        next step (PyBullet clears them after each). Without it two motors at their limit let the
        fingers slide together along their closing direction, and the handle with them: it moved 5 mm
        in the fingers at the first pull. A joint force of 235 N in place of the motor flung a 50 g
        finger through its stop the one step a pad's contact dropped out of the manifold."""
        c = self.sim.client
        (q_a, v_a), (q_b, v_b) = (s[:2] for s in pb.getJointStates(self.sim.robot, self.sim.finger_joints,
                                                                    physicsClientId=c))
        pull = LINKAGE_STIFFNESS * (q_a - q_b) + LINKAGE_DAMPING * (v_a - v_b)
        for finger, f in zip(self.sim.finger_joints, (-pull, pull), strict=True):
            pb.setJointMotorControl2(self.sim.robot, finger, pb.TORQUE_CONTROL, force=f, physicsClientId=c)

    def command_fingers(self, target: float, speed: float | None = None) -> None:
        g = self.settings.robot.gripper
        self.squeezing = None
        pb.setPhysicsEngineParameter(numSolverIterations=SOLVER_ITERATIONS, physicsClientId=self.sim.client)
        for finger in self.sim.finger_joints:
            pb.setJointMotorControl2(self.sim.robot, finger, pb.POSITION_CONTROL, targetPosition=target,
                                     force=g.grip_force,
                                     maxVelocity=g.closing_speed if speed is None else speed,
                                     physicsClientId=self.sim.client)

    def grip_lost(self, grip: Grip) -> str | None:
        """Why the fingers no longer hold the handle (a finger off it, or the handle slipped in them
        beyond :data:`SLIP_DISTANCE` or :data:`SLIP_ANGLE`), or None while they do."""
        if self.fingers_hold(grip.link):
            self.off_handle = 0
        else:
            # A pad's contact may drop out of a step's manifold while it still presses: a finger has
            # left the handle once it has had no contact for LOST_STEPS steps in a row.
            self.off_handle += 1
            if self.off_handle >= LOST_STEPS:
                return "lost grip: a finger left the handle"
        position, orientation = pb.getLinkState(self.sim.puzzle, grip.link, computeForwardKinematics=True,
                                                physicsClientId=self.sim.client)[4:6]
        now = inverse(matrix(position, orientation)) @ matrix(*self.sim.tool_pose())
        moved = float(np.linalg.norm(now[:3, 3] - grip.tool_at_link[:3, 3]))
        turn = rotation_error(now[:3, :3], grip.tool_at_link[:3, :3])
        turned = float(np.linalg.norm(turn))
        if moved > SLIP_DISTANCE or turned > SLIP_ANGLE:
            axis = np.round(grip.tool_at_link[:3, :3].T @ turn / max(turned, 1e-12), 2).tolist()
            return (f"slipped: the handle moved {moved * 1000:.1f} mm and turned {turned * 1000:.0f} mrad in the "
                    f"fingers (axis {axis} in the tool's frame)")
        return None

    def hold(self, link_index: int) -> Grip:
        """The fingers have closed on the link: from now on it is held by their friction alone,
        watched for a slip from the pose the tool has on it now."""
        position, orientation = pb.getLinkState(self.sim.puzzle, link_index, computeForwardKinematics=True,
                                                physicsClientId=self.sim.client)[4:6]
        self.grip = Grip(link_index, inverse(matrix(position, orientation)) @ matrix(*self.sim.tool_pose()))
        self.lost = None
        self.off_handle = 0
        return self.grip

    def open_gripper(self, held: np.ndarray | None = None) -> None:
        """Release: the fingers open, slowly (:data:`OPEN_SLOW_SPEED`) until neither touches the
        handle (at most :data:`OPEN_SLOW_STEPS`), then at full speed; while they begin to open on the
        handle the tool rises straight up off its top (:data:`RELEASE_LIFT_SPEED`), so no pad drags
        it sideways; fingers that stall on a handle later are lifted off it too.
        The arm holds ``held``, its last command (a loaded arm's PD
        servos sag off it: commanded where it stood, it let go of the load it carried and shoved the
        handle as the pads opened), or where it stands. ExecutionError if they are not open after
        :data:`OPEN_STEPS`."""
        handles = {link for _, link in self.planned}
        self.grip = None
        self.phase = "opening"
        q = self.sim.robot_state() if held is None else held
        g = self.settings.robot.gripper
        slow = bool(handles)
        self.command_fingers(0.0, OPEN_SLOW_SPEED if slow else g.closing_speed)
        lifted = False
        if slow and any(any(self.fingers_touching(link)) for link in handles):
            # The tool rises off the handle as the fingers open. Opened in place, a pad on a knob
            # left a few tens of mrad off square (its contact across the closing direction) dragged
            # it along at the pad's speed, 16-22 mm into a wall (Move N Times 4 and 9417).
            lifted = True
            lift_tool(self.sim, g.grasp_depth + LIFT_MARGIN, RELEASE_LIFT_SPEED, self.settings.follow, self.on_step)
            q = self.sim.robot_state()
        for step in range(OPEN_STEPS):
            if np.max(self.sim.finger_state()) < 1e-3:
                break
            if slow and (step >= OPEN_SLOW_STEPS or not any(any(self.fingers_touching(link)) for link in handles)):
                slow = False
                self.command_fingers(0.0)
            if (not lifted and not slow and step >= OPEN_SLOW_STEPS + OPEN_STALL_STEPS
                    and self.finger_speed() < 0.2 * g.closing_speed
                    and any(any(self.fingers_touching(link)) for link in handles)):
                # A finger stalled on the handle: the arm presses it there (the tool sits off the
                # handle's centre after a slip, or the handle leans on a wall; Move N Times 3). The
                # tool rises off the handle's top, the pads sliding up it; the fingers open above it.
                lifted = True
                lift_tool(self.sim, g.grasp_depth + LIFT_MARGIN, OPEN_LIFT_SPEED, self.settings.follow, self.on_step)
                q = self.sim.robot_state()
            command(self.sim, q)
            pb.stepSimulation(physicsClientId=self.sim.client)
            self.on_step()
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
