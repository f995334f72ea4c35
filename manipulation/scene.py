"""A PyBullet world holding the mobile iiwa and a (scaled) puzzle.

Two worlds are used per run: the *simulation*, where everything moves by
physics only (the robot by its joint motors, puzzle objects only when the
robot's fingers hold them by friction), and a *planning* copy, where
IK and collision queries may set joint values freely without disturbing the
simulation.

Both are built the same way, robot self-collision included: the planner
refuses a robot that touches itself, so the simulation must not let the robot
pass through itself either. (It once did: Move N Times 4's follower folded
the arm 2-5 cm into its own base, and the released robot could not be
planned from; see docs/manipulation/README.md.)
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pybullet as pb

from phyrogen_core.chain import KinematicChain
from phyrogen_core.export.urdf import chain_to_urdf

from .physics import PuzzleMaterial, joint_damping, joint_friction
from .placement import Placement
from .robot import ARM_JOINTS, BASE_LINK, FINGER_JOINTS, ROBOT_JOINTS, TOOL_LINK, RobotSpec, mobile_iiwa_urdf

COLLISION_MARGIN = 0.004
"""Metres: closer than this, robot and puzzle count as colliding while planning."""

ROBOT_CONTACT_TOLERANCE = 1e-4
"""Metres: a robot-puzzle contact deeper than this (numerical noise) is a collision, unless planned."""
PUZZLE_CONTACT_TOLERANCE = 1e-3
"""Metres: puzzle parts may touch (certificates count touching as free), but PyBullet's contacts
blur by about a millimetre (:data:`manipulation.replay.PENETRATION_TOLERANCE`); deeper is a collision."""

PUZZLE_CONTACT_FORCE = 1.0
"""Newtons: puzzle parts that touch carry no load along a valid path (their joints hold them; 0.0 N
over 88,000 door-wall contact points of a Move N Times run); a contact pressed harder than this is
an object pushing another, which no certificate does. A blocked object may stay under
:data:`PUZZLE_CONTACT_TOLERANCE` deep (Simple Slider: 0.9 mm at 330 N), so depth alone misses it."""

TRACKING_TOLERANCE = 0.002
"""Metres: two puzzle parts the path brings this close (or touching) may touch under load while
an object is pulled along it (the grasp tracks the path within about a millimetre)."""

PROBE_HEIGHT = 2.0
"""Metres: height of the floor probe (:meth:`World.floor_clear`), above the tucked robot."""
PUZZLE_FRICTION = 0.5
"""The puzzle's links' own friction coefficient (PyBullet's default for a URDF link)."""
PAD_FRICTION_ANCHOR = True
"""Whether the finger pads' contacts keep friction anchors (PyBullet's ``frictionAnchor``): a pad
that sticks to a handle then holds its contact point instead of creeping under a steady pull."""
SELF_COLLISION_SKIP = 2
"""Robot links this close along the chain touch by construction; their contacts are ignored."""


@dataclass(frozen=True)
class Contact:
    """A contact between two links: each named by its body (``robot`` or ``puzzle``) and link."""

    body_a: str
    link_a: str
    body_b: str
    link_b: str
    depth: float
    """Metres of penetration (>= 0)."""
    force: float = 0.0
    """Newtons of normal force in the contact."""
    time: float = 0.0
    """Simulated seconds since the start of the run."""
    phase: str = ""
    """What the robot was doing: driving, closing, following, opening or holding."""
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Where (world metres, on the first link)."""

    def describe(self) -> str:
        return (f"{self.body_a} link {self.link_a} hit {self.body_b} link {self.link_b}, "
                f"{self.depth * 1000:.1f} mm deep, {self.force:.0f} N, at t={self.time:.2f} s ({self.phase})")


@dataclass(frozen=True)
class SceneFiles:
    """The URDF files a world loads (written once per run into a temporary folder)."""

    robot_urdf: Path
    puzzle_urdf: Path


def write_scene_files(folder: Path, chain: KinematicChain, spec: RobotSpec) -> SceneFiles:
    """Write the robot URDF and the scaled puzzle URDF (with its meshes) under ``folder``."""
    folder = Path(folder)
    robot = folder / "mobile_iiwa.urdf"
    robot.write_text(mobile_iiwa_urdf(spec), encoding="utf-8")
    urdf_text, meshes = chain_to_urdf(chain, "meshes")
    puzzle = folder / f"{chain.name}.urdf"
    puzzle.write_text(urdf_text, encoding="utf-8")
    if meshes:
        (folder / "meshes").mkdir(exist_ok=True)
        for name, text in meshes.items():
            (folder / "meshes" / name).write_text(text, encoding="utf-8")
    return SceneFiles(robot, puzzle)


class World:
    """One PyBullet client with the robot, the puzzle and a floor (visual only)."""

    def __init__(self, files: SceneFiles, chain: KinematicChain, placement: Placement, gui: bool = False,
                 puzzle_self_collision: bool = True, spec: RobotSpec | None = None,
                 material: PuzzleMaterial | None = None):
        spec = spec or RobotSpec()
        material = material or PuzzleMaterial()
        self.spec = spec
        self.client = pb.connect(pb.GUI if gui else pb.DIRECT)
        self.chain = chain
        self.placement = placement
        c = self.client
        pb.setGravity(0, 0, -9.81, physicsClientId=c)
        pb.setTimeStep(1 / 240, physicsClientId=c)
        self.floor = _floor(c)
        flags = pb.URDF_USE_INERTIA_FROM_FILE | pb.URDF_USE_SELF_COLLISION | pb.URDF_USE_SELF_COLLISION_EXCLUDE_PARENT
        self.robot = pb.loadURDF(str(files.robot_urdf), useFixedBase=True, physicsClientId=c, flags=flags)
        ox, oy = placement.offset
        # Without URDF_USE_SELF_COLLISION PyBullet lets the links of one body (the puzzle's objects
        # and walls) pass through each other: an object pulled into its blocker went 450 mm deep.
        puzzle_flags = pb.URDF_USE_INERTIA_FROM_FILE
        if puzzle_self_collision:
            puzzle_flags |= pb.URDF_USE_SELF_COLLISION | pb.URDF_USE_SELF_COLLISION_EXCLUDE_PARENT
        self.puzzle = pb.loadURDF(str(files.puzzle_urdf), basePosition=(ox, oy, 0.0), useFixedBase=True,
                                  physicsClientId=c, flags=puzzle_flags)
        self.robot_link = _link_indices(self.robot, c)
        self.robot_joints = [self.robot_link[_child_of(self.robot, name, c)] for name in ROBOT_JOINTS]
        self.arm_columns = [ROBOT_JOINTS.index(n) for n in ARM_JOINTS]
        self.tool = self.robot_link[TOOL_LINK]
        self.base_link = self.robot_link[BASE_LINK]
        self.puzzle_link = _link_indices(self.puzzle, c)
        self.puzzle_joints = [self.puzzle_link[chain.joint(n).child] for n in chain.joint_order]
        self.finger_joints = [self.robot_link[_child_of(self.robot, name, c)] for name in FINGER_JOINTS]
        self.finger_links = frozenset(self.finger_joints)
        info = [pb.getJointInfo(self.robot, j, physicsClientId=c) for j in self.robot_joints]
        self.lower = np.array([i[8] for i in info])
        self.upper = np.array([i[9] for i in info])
        # PyBullet's IK and Jacobians speak of every movable joint, fingers included, in joint order.
        movable = [j for j in range(pb.getNumJoints(self.robot, physicsClientId=c))
                   if pb.getJointInfo(self.robot, j, physicsClientId=c)[2] != pb.JOINT_FIXED]
        self._dof = len(movable)
        self._robot_dof = [movable.index(j) for j in self.robot_joints]
        self._finger_dof = [movable.index(j) for j in self.finger_joints]
        self.finger_closed = float(pb.getJointInfo(self.robot, self.finger_joints[0], physicsClientId=c)[9])
        for link in self.finger_joints:
            # PyBullet's contact friction is the product of the two bodies' coefficients: the pad's is
            # set so that pad on puzzle gives the pad's stated friction.
            pb.changeDynamics(self.robot, link, lateralFriction=spec.gripper.pad_friction / PUZZLE_FRICTION,
                              frictionAnchor=PAD_FRICTION_ANCHOR, physicsClientId=c)
        friction, damping = joint_friction(chain, material), joint_damping(chain, material)
        for name, j in zip(chain.joint_order, self.puzzle_joints, strict=True):
            # Coulomb friction as PyBullet models it: a motor holding zero velocity with that force.
            pb.setJointMotorControl2(self.puzzle, j, pb.VELOCITY_CONTROL, targetVelocity=0.0,
                                     force=friction[name], physicsClientId=c)
            pb.changeDynamics(self.puzzle, j, jointDamping=damping[name], physicsClientId=c)
        _ignore_near_links(self.robot, c)
        self.puzzle_link_name = {index: name for name, index in self.puzzle_link.items()}
        self.robot_link_name = {index: name for name, index in self.robot_link.items()}
        self.puzzle_owner = {index: chain.link(name).object_name or name for name, index in self.puzzle_link.items()}
        if puzzle_self_collision:
            _ignore_rigid_pairs(self.puzzle, chain, self.puzzle_link, c)
        self._probes: dict[float, int] = {}

    def close(self) -> None:
        if pb.isConnected(self.client):
            pb.disconnect(self.client)

    # -- state -------------------------------------------------------------
    def _joint_values(self, body: int, joints: Sequence[int]) -> np.ndarray:
        states = pb.getJointStates(body, joints, physicsClientId=self.client)
        return np.array([s[0] for s in states])

    def _reset_joints(self, body: int, joints: Sequence[int], values: Sequence[float]) -> None:
        for j, v in zip(joints, values, strict=True):
            pb.resetJointState(body, j, float(v), physicsClientId=self.client)

    def robot_state(self) -> np.ndarray:
        return self._joint_values(self.robot, self.robot_joints)

    def set_robot(self, q: Sequence[float]) -> None:
        """Place the robot (planning world, or the simulation's initial state only)."""
        pb.resetJointStatesMultiDof(self.robot, self.robot_joints, [[float(v)] for v in q],
                                    physicsClientId=self.client)

    def finger_state(self) -> np.ndarray:
        """The two fingers' joint values (0 open, :attr:`finger_closed` closed)."""
        return self._joint_values(self.robot, self.finger_joints)

    def set_fingers(self, values: Sequence[float]) -> None:
        """Place the fingers (planning world, renderer, or the simulation's initial state only)."""
        self._reset_joints(self.robot, self.finger_joints, values)

    def all_dof(self, q: Sequence[float]) -> list[float]:
        """Robot joints ``q`` with the fingers as they are, in PyBullet's order of movable joints."""
        full = [0.0] * self._dof
        for k, v in zip(self._robot_dof, q, strict=True):
            full[k] = float(v)
        for k, v in zip(self._finger_dof, self.finger_state(), strict=True):
            full[k] = float(v)
        return full

    def robot_dof(self, full: Sequence[float]) -> np.ndarray:
        """The robot joints (:data:`ROBOT_JOINTS` order) out of a vector over every movable joint."""
        return np.asarray(full, dtype=float)[self._robot_dof]

    def inverse_kinematics(self, position: Sequence[float], orientation: Sequence[float], lower: np.ndarray,
                           upper: np.ndarray, rest: Sequence[float]) -> np.ndarray:
        """PyBullet's null-space IK for the tool over the robot joints (fingers held where they are)."""
        fingers = self.finger_state()
        low, high = self.all_dof(lower), self.all_dof(upper)
        for k, v in zip(self._finger_dof, fingers, strict=True):
            low[k], high[k] = v - 1e-6, v + 1e-6
        ranges = [h - lo for lo, h in zip(low, high, strict=True)]
        answer = pb.calculateInverseKinematics(self.robot, self.tool, list(position), list(orientation),
                                               lowerLimits=low, upperLimits=high, jointRanges=ranges,
                                               restPoses=self.all_dof(rest), maxNumIterations=40,
                                               residualThreshold=1e-5, physicsClientId=self.client)
        return self.robot_dof(answer)

    def puzzle_state(self) -> np.ndarray:
        """Puzzle joint values in the scaled scene's units (joint order)."""
        return self._joint_values(self.puzzle, self.puzzle_joints)

    def set_puzzle(self, values: Sequence[float]) -> None:
        """Planning world only: the simulation moves puzzle joints by physics alone."""
        self._reset_joints(self.puzzle, self.puzzle_joints, values)

    def tool_pose(self) -> tuple[np.ndarray, np.ndarray]:
        state = pb.getLinkState(self.robot, self.tool, computeForwardKinematics=True, physicsClientId=self.client)
        return np.array(state[4]), np.array(state[5])

    def link_pose(self, link: int) -> tuple[np.ndarray, np.ndarray]:
        state = pb.getLinkState(self.puzzle, link, computeForwardKinematics=True, physicsClientId=self.client)
        return np.array(state[4]), np.array(state[5])

    # -- queries -----------------------------------------------------------
    def in_collision(self, margin: float = COLLISION_MARGIN) -> bool:
        """Robot against puzzle (closer than ``margin``) or against itself, at the current joint values.

        One broad-phase pass answers both.
        """
        c = self.client
        pb.performCollisionDetection(physicsClientId=c)
        for point in pb.getContactPoints(self.robot, physicsClientId=c):
            other, distance = point[2], point[8]
            if (other == self.puzzle and distance < margin) or (other == self.robot and distance < 0.0):
                return True
        return False

    def touches_itself(self) -> bool:
        """Whether the robot touched itself in the last physics step (the self part of
        :meth:`in_collision`, from the contacts the step already found)."""
        points = pb.getContactPoints(self.robot, self.robot, physicsClientId=self.client)
        return any(p[8] < 0.0 for p in points)

    def clearance(self, up_to: float, planned: frozenset[tuple[int, int]] = frozenset()) -> float:
        """Smallest robot-puzzle distance (negative: penetration), or ``up_to`` if nothing is closer;
        ``planned`` (robot link, puzzle link) pairs (the fingers on a held knob) left out."""
        points = pb.getClosestPoints(self.robot, self.puzzle, up_to, physicsClientId=self.client)
        return min([up_to] + [p[8] for p in points if (p[3], p[4]) not in planned])

    def penetration(self, planned: frozenset[tuple[int, int]] = frozenset()) -> float:
        """Deepest robot-puzzle penetration (metres, >= 0) among the last step's contacts, those of
        ``planned`` (robot link, puzzle link) pairs left out."""
        points = pb.getContactPoints(self.robot, self.puzzle, physicsClientId=self.client)
        return max([0.0] + [-p[8] for p in points if (p[3], p[4]) not in planned])

    def unplanned_contact(self, planned: frozenset[tuple[int, int]] = frozenset(),
                          plan_touches: Callable[[int, int], bool] = lambda a, b: False) -> Contact | None:
        """A contact of the last physics step that the plan did not allow, or None: the deepest
        robot-puzzle one, else the most loaded one between puzzle parts.

        Allowed: ``planned`` (robot link, puzzle link) pairs (a closed gripper's fingers on the
        grasped object), robot-puzzle contact within :data:`ROBOT_CONTACT_TOLERANCE` (numerical
        noise), and puzzle parts touching within :data:`PUZZLE_CONTACT_TOLERANCE` with at most
        :data:`PUZZLE_CONTACT_FORCE` (their certificates let them touch; PyBullet's contacts blur
        by about a millimetre), or under load where ``plan_touches(link_a, link_b)``: the path
        itself brings the two within tracking error of each other there (a certificate may slide
        an object along a wall: Move N Times' target passes 0.9 mm from one), so the object's
        tracking error presses it on."""
        c = self.client
        worst: Contact | None = None
        for point in pb.getContactPoints(self.robot, self.puzzle, physicsClientId=c):
            depth = -point[8]
            if depth <= ROBOT_CONTACT_TOLERANCE or (point[3], point[4]) in planned:
                continue
            if worst is None or depth > worst.depth:
                worst = Contact("robot", self.robot_link_name[point[3]], "puzzle",
                                self.puzzle_link_name[point[4]], depth, point[9], position=_xyz(point[5]))
        if worst is not None:
            return worst
        for point in pb.getContactPoints(self.puzzle, self.puzzle, physicsClientId=c):
            depth = -point[8]
            force = point[9]
            if depth <= PUZZLE_CONTACT_TOLERANCE and (force <= PUZZLE_CONTACT_FORCE
                                                      or plan_touches(point[3], point[4])):
                continue
            if worst is None or (force, depth) > (worst.force, worst.depth):
                a, b = sorted((self.puzzle_link_name[point[3]], self.puzzle_link_name[point[4]]))
                worst = Contact("puzzle", a, "puzzle", b, depth, force, position=_xyz(point[5]))
        return worst

    def distance_between(self, link_a: int, link_b: int, up_to: float) -> float:
        """The distance between two puzzle links as the puzzle stands (``up_to`` if farther)."""
        points = pb.getClosestPoints(self.puzzle, self.puzzle, up_to, link_a, link_b, physicsClientId=self.client)
        return min([up_to] + [p[8] for p in points])

    def base_clear(self, xy: np.ndarray, heading: float, margin: float = COLLISION_MARGIN) -> bool:
        """Whether the base alone, at ``xy`` facing ``heading``, keeps ``margin`` from the puzzle
        (moves the planning world's base there)."""
        q = self.robot_state()
        q[:3] = (xy[0], xy[1], heading)
        self.set_robot(q)
        return not pb.getClosestPoints(self.robot, self.puzzle, margin, linkIndexA=self.base_link,
                                       physicsClientId=self.client)

    def floor_clear(self, xy: np.ndarray, radius: float) -> bool:
        """Whether a vertical cylinder of ``radius`` standing at ``xy``, as tall as the tucked
        robot, clears the puzzle (planning world: the probe is a body of its own)."""
        c = self.client
        if radius not in self._probes:
            shape = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=radius, height=PROBE_HEIGHT, physicsClientId=c)
            self._probes[radius] = pb.createMultiBody(0, shape, -1, (0.0, 0.0, -2 * PROBE_HEIGHT),
                                                      physicsClientId=c)
        probe = self._probes[radius]
        pb.resetBasePositionAndOrientation(probe, (float(xy[0]), float(xy[1]), PROBE_HEIGHT / 2), (0, 0, 0, 1),
                                           physicsClientId=c)
        return not pb.getClosestPoints(probe, self.puzzle, 0.0, physicsClientId=c)

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """6 x 10 tool Jacobian (linear rows first) at robot joints ``q`` (the fingers, which do not
        move the tool point, left out)."""
        zeros = [0.0] * self._dof
        linear, angular = pb.calculateJacobian(self.robot, self.tool, (0.0, 0.0, 0.0), self.all_dof(q),
                                               zeros, zeros, physicsClientId=self.client)
        return np.vstack([np.asarray(linear), np.asarray(angular)])[:, self._robot_dof]


def open_worlds(files: SceneFiles, chain: KinematicChain, placement: Placement, gui: bool = False,
                puzzle_self_collision: bool = True, spec: RobotSpec | None = None,
                material: PuzzleMaterial | None = None) -> tuple[World, World]:
    """The simulation (in a window when ``gui``) and the planning world of one run, built alike:
    the same files, the same collision filters, so the same joint values collide the same way.

    ``puzzle_self_collision`` False builds both as before the puzzle's objects collided with each
    other (a negative control: an invalid path then executes)."""
    simulation = World(files, chain, placement, gui, puzzle_self_collision, spec, material)
    return simulation, World(files, chain, placement, False, puzzle_self_collision, spec, material)


def _floor(client: int) -> int:
    shape = pb.createVisualShape(pb.GEOM_BOX, halfExtents=(20, 20, 0.005), rgbaColor=(0.85, 0.85, 0.82, 1),
                                 physicsClientId=client)
    # Visual only: the puzzle and the robot stand on their own fixed roots.
    return pb.createMultiBody(0, -1, shape, (0, 0, -0.006), physicsClientId=client)


def _ignore_near_links(robot: int, client: int) -> None:
    count = pb.getNumJoints(robot, physicsClientId=client)
    parent = {j: pb.getJointInfo(robot, j, physicsClientId=client)[16] for j in range(count)}
    parent[-1] = None

    def ancestors(link: int) -> list[int]:
        out = []
        while parent[link] is not None and len(out) < SELF_COLLISION_SKIP:
            link = parent[link]
            out.append(link)
        return out

    for link in parent:
        for other in ancestors(link):
            pb.setCollisionFilterPair(robot, robot, link, other, 0, physicsClientId=client)


def _xyz(v: Sequence[float]) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def rigid_groups(chain: KinematicChain) -> dict[str, str]:
    """Per link with collision shapes: the group of links that never move relative to it (the
    scenery: every link fixed to the root; else its object). Links of one group never need a
    collision check, and scenery pieces touch by construction (a corridor's walls meet)."""
    fixed = {chain.root}
    grew = True
    while grew:
        more = {j.child for j in chain.joints if j.parent in fixed and not j.is_active} - fixed
        fixed |= more
        grew = bool(more)
    return {link.name: ("scenery" if link.name in fixed else (link.object_name or link.name))
            for link in chain.links if link.collisions}


def _ignore_rigid_pairs(body: int, chain: KinematicChain, index: dict[str, int], client: int) -> None:
    """PyBullet checks every pair of links of a self-colliding body but parent and child; pairs
    that cannot move apart (two walls, two shapes of one object) are switched off, or fixed walls
    that meet would report contact at every step."""
    groups = rigid_groups(chain)
    names = sorted(groups)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if groups[a] == groups[b]:
                pb.setCollisionFilterPair(body, body, index[a], index[b], 0, physicsClientId=client)


def _link_indices(body: int, client: int) -> dict[str, int]:
    out = {pb.getBodyInfo(body, physicsClientId=client)[0].decode(): -1}
    for j in range(pb.getNumJoints(body, physicsClientId=client)):
        out[pb.getJointInfo(body, j, physicsClientId=client)[12].decode()] = j
    return out


def _child_of(body: int, joint_name: str, client: int) -> str:
    for j in range(pb.getNumJoints(body, physicsClientId=client)):
        info = pb.getJointInfo(body, j, physicsClientId=client)
        if info[1].decode() == joint_name:
            return info[12].decode()
    raise ValueError(f"robot has no joint {joint_name!r}")


def temporary_folder() -> tempfile.TemporaryDirectory:
    return tempfile.TemporaryDirectory(prefix="phyrogen_manipulation_")
