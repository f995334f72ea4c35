"""Rolling a puzzle's MJCF file out in MuJoCo through its own servos: the certificate driven, and a
blocked push.

Both rollouts use the file as written (:func:`phyrogen_core.export.chain_to_mjcf`): its joint
friction and damping, its contact parameters and its position servos with their force limits. Only
the servos' targets (``ctrl``) are set from outside:

- :func:`drive_certificate` starts at the ``start`` keyframe and moves every servo's target along the
  certificate, densified so that no collision point moves more than 2 mm between targets, one target
  per :data:`STEPS_PER_STATE` steps (at most 0.2 m/s at any point of a part), then holds the last
  state for :data:`SETTLE_STEPS` steps. It passes when every goal joint ends within the goal's
  tolerance and no contact between different objects was ever deeper than 1 mm.
- :func:`push_target` is the negative control: the target starts on the straight line from its start
  to its goal, at the last state our collision model finds free before the line first meets
  something (within 8 micrometres of the contact); its servos' targets walk the straight line on to
  the goal at the drive's pace (each servo at most :data:`PUSH_FORCE`, 20 N at the part), and every
  other servo holds its joint where it is, for :data:`PUSH_STEPS` steps (2 s). It passes when the
  target touched another object, no contact ever got 2 mm deep, the target stayed out of its goal,
  and no collision point of another movable part moved :data:`BLOCKER_STILL` or more.
  ``contacts=False`` runs the same push with contacts switched off: the target must then travel far
  past its stop, so that stopping was the contacts' doing, not a weak servo's.

Every count here is of simulation steps (1 ms each); nothing reads a clock.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from phyrogen_core.chain import KinematicChain, Role
from phyrogen_core.export.mjcf import object_of_link
from phyrogen_core.export.mjcf_dynamics import DYNAMICS
from phyrogen_core.puzzle import Goal
from solver.collision.model import CollisionModel
from solver.planning.problem import segment_points

RESOLUTION = 0.002
"""Metres any collision point moves between two servo targets: the certificate check's 2 mm."""
STEPS_PER_STATE = 10
SETTLE_STEPS = 1000
PUSH_STEPS = 2000
DRIVE_DEPTH = 0.001
"""Metres: the deepest contact a certificate rollout may show (the PyBullet referee's threshold)."""
PUSH_DEPTH = 0.002
TOUCH_HALVINGS = 8
"""The push begins within 2 mm / 2^8 (8 micrometres) of the first contact."""
PUSH_FORCE = 20.0
"""Newtons the target's servos push with at most (at its farthest point for a hinge): a firm push
by hand, a tenth of the servos' limit in the file."""
BLOCKER_STILL = 0.002
"""Metres any collision point of a part not pushed may move while the target pushes into it."""


@dataclass(frozen=True)
class Rollout:
    """What one rollout measured."""

    steps: int
    deepest: float
    """Metres: the deepest contact between geoms of different objects over every step."""
    between: tuple[str, ...]
    """The two bodies of that contact (empty without any)."""
    goal_error: float
    """The largest distance of a goal joint from its goal value at the end (m or rad)."""
    reached: bool
    """Every goal joint within the goal's tolerance at the end."""
    others_moved: float
    """Metres: how far the farthest-moving collision point of a part the servos only held went."""
    target_moved: float
    """Metres: how far the target's farthest-moving collision point went from where the rollout began."""
    touched: bool
    """Whether the target touched anything of another object."""


def dense_path(chain: KinematicChain, states: Sequence[Sequence[float]]) -> np.ndarray:
    """``states`` with points in between so that no collision point moves more than 2 mm per step."""
    states = np.asarray(states, dtype=float)
    if len(states) < 2:
        return states
    steps = CollisionModel(chain).motion_steps(RESOLUTION)
    return np.concatenate([states[:1], segment_points(states, steps)[0]])


class _Scene:
    """The model and data of one file, indexed by the chain's joint order."""

    def __init__(self, xml: str, chain: KinematicChain, start: Sequence[float], contacts: bool = True):
        self.model = mujoco.MjModel.from_xml_string(xml)
        if not contacts:
            self.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
        self.data = mujoco.MjData(self.model)
        self.chain = chain
        model = self.model
        self.qpos = np.array([model.jnt_qposadr[model.joint(name).id] for name in chain.joint_order])
        self.ctrl = np.array([model.actuator(name).id for name in chain.joint_order])
        objects = {name: i for i, name in enumerate(sorted({object_of_link(link) for link in chain.links}))}
        # Geoms of the world body (the floor) belong to no object: -1 never equals an object.
        self.geom_object = np.array([objects[object_of_link(chain.link(model.body(body).name))] if body else -1
                                     for body in model.geom_bodyid])
        self.target_object = objects[_target_object(chain)]
        self.set(start)

    def set(self, state: Sequence[float]) -> None:
        self.data.qpos[self.qpos] = state
        self.data.qvel[:] = 0
        self.data.ctrl[self.ctrl] = state
        mujoco.mj_forward(self.model, self.data)

    def state(self) -> np.ndarray:
        return self.data.qpos[self.qpos].copy()

    def deepest(self) -> tuple[float, tuple[int, int], bool]:
        """The deepest contact between different objects now, its geoms, and whether the target touches."""
        n = self.data.ncon
        if n == 0:
            return 0.0, (-1, -1), False
        geoms = self.data.contact.geom[:n]
        a, b = self.geom_object[geoms[:, 0]], self.geom_object[geoms[:, 1]]
        between = (a != b) & (a >= 0) & (b >= 0)
        if not between.any():
            return 0.0, (-1, -1), False
        depth = np.where(between, -self.data.contact.dist[:n], 0.0)
        k = int(np.argmax(depth))
        touches = bool((between & ((a == self.target_object) | (b == self.target_object))).any())
        return max(float(depth[k]), 0.0), (int(geoms[k, 0]), int(geoms[k, 1])), touches

    def run(self, targets: np.ndarray, steps_per_target: int, settle: int) -> tuple[int, float, tuple[str, ...], bool]:
        """Each servo target held for ``steps_per_target`` steps, the last for ``settle`` more."""
        deepest, between, touched, steps = 0.0, (-1, -1), False, 0
        schedule = [(target, steps_per_target) for target in targets] + [(targets[-1], settle)]
        for target, count in schedule:
            self.data.ctrl[self.ctrl] = target
            for _ in range(count):
                mujoco.mj_step(self.model, self.data)
                steps += 1
                depth, geoms, touches = self.deepest()
                touched |= touches
                if depth > deepest:
                    deepest, between = depth, geoms
        names = tuple(self.model.body(self.model.geom_bodyid[g]).name for g in between) if between[0] >= 0 else ()
        return steps, deepest, names, touched


def drive_certificate(xml: str, chain: KinematicChain, certificate: Sequence[Sequence[float]], goal: Goal) -> Rollout:
    """The certificate driven through the file's servos (module docstring)."""
    scene = _Scene(xml, chain, certificate[0])
    steps, deepest, between, touched = scene.run(dense_path(chain, certificate), STEPS_PER_STATE, SETTLE_STEPS)
    end = scene.state()
    error = _goal_error(chain, end, goal)
    moved = _farthest_move(chain, chain.link_transforms(certificate[0]), chain.link_transforms(end),
                           _object_joints(chain, _target_object(chain)))
    return Rollout(steps, deepest, between, error, error <= goal.tolerance + 1e-12, 0.0, moved, touched)


def push_target(xml: str, chain: KinematicChain, certificate: Sequence[Sequence[float]], goal: Goal,
                contacts: bool = True, edit: Callable[[mujoco.MjModel, set[str]], None] | None = None,
                paced: bool = True) -> Rollout:
    """The target pushed from its start straight toward its goal, every other part held (module docstring).

    ``edit(model, held)``, when given, changes the loaded model before the push (``held``: the joints
    whose servos hold their parts): for the controls of scripts/mjcf_rollouts.py. ``paced=False``
    aims the target's servos at the goal at once: the target then speeds up at its force limit
    wherever nothing stops it (sliding along a wall, say) and meets the next blocker at speed."""
    start = np.asarray(certificate[0], dtype=float)
    aimed = start.copy()
    for name, value in goal.values.items():
        aimed[chain.joint_order.index(name)] = value
    begin = _first_touch(chain, start, aimed)
    scene = _Scene(xml, chain, begin, contacts)
    target = _target_object(chain)
    for name in _object_joints(chain, target):
        scene.model.actuator_forcerange[scene.model.actuator(name).id] *= PUSH_FORCE / DYNAMICS.servo_force
    held = {joint.name for joint in chain.active_joints} - _object_joints(chain, target)
    if edit is not None:
        edit(scene.model, held)
    before = chain.link_transforms(begin)
    # At the drive's pace: the servo targets walk the straight line, so the target moves no faster
    # than 0.2 m/s until it is stopped, and then presses with at most PUSH_FORCE.
    targets = dense_path(chain, [begin, aimed])[:PUSH_STEPS // STEPS_PER_STATE] if paced else aimed[None, :]
    steps, deepest, between, touched = scene.run(targets, STEPS_PER_STATE, PUSH_STEPS - len(targets) * STEPS_PER_STATE)
    end = chain.link_transforms(scene.state())
    error = _goal_error(chain, scene.state(), goal)
    return Rollout(steps, deepest, between, error, error <= goal.tolerance + 1e-12,
                   _farthest_move(chain, before, end, held),
                   _farthest_move(chain, before, end, _object_joints(chain, target)), touched)


def _first_touch(chain: KinematicChain, start: np.ndarray, aimed: np.ndarray) -> np.ndarray:
    """The last state our collision model finds free on the straight line from ``start`` to ``aimed``
    before the line first meets something, to within :data:`TOUCH` of the first colliding state
    (``aimed`` when nothing is met)."""
    model = CollisionModel(chain)
    line = dense_path(chain, [start, aimed])
    blocked = np.flatnonzero(~model.check(line))
    if not len(blocked):
        return line[-1]
    if blocked[0] == 0:
        return line[0]
    free, hit = line[blocked[0] - 1], line[blocked[0]]
    for _ in range(TOUCH_HALVINGS):  # the dense line's 2 mm halved down to TOUCH
        middle = (free + hit) / 2
        free, hit = (middle, hit) if model.is_valid(middle) else (free, middle)
    return free


def _target_object(chain: KinematicChain) -> str:
    targets = {object_of_link(link) for link in chain.links if link.role is Role.TARGET}
    if len(targets) != 1:
        raise ValueError(f"chain {chain.name!r} has {len(targets)} target objects; a rollout needs one")
    return targets.pop()


def _object_joints(chain: KinematicChain, name: str) -> set[str]:
    return {joint for joint in chain.joint_order if chain.object_of_joint(joint) == name}


def _goal_error(chain: KinematicChain, state: np.ndarray, goal: Goal) -> float:
    values = chain.state_dict(state)
    return max(abs(values[name] - value) for name, value in goal.values.items())


def _farthest_move(chain: KinematicChain, before: dict[str, np.ndarray], after: dict[str, np.ndarray],
                   joints: set[str]) -> float:
    """Metres: the largest displacement of a collision-bounds corner of a link moved by ``joints``."""
    from phyrogen_core.export.urdf import collision_bounds

    moved = 0.0
    for link in chain.links:
        if not link.collisions or link.object_name is None:
            continue
        if not any(chain.object_of_joint(j) == link.object_name for j in joints):
            continue
        low, high = collision_bounds(link)
        corners = np.array([[x, y, z, 1.0] for x in (low[0], high[0]) for y in (low[1], high[1])
                            for z in (low[2], high[2])])
        shift = (corners @ after[link.name].T - corners @ before[link.name].T)[:, :3]
        moved = max(moved, float(np.sqrt((shift ** 2).sum(axis=1)).max()))
    return moved

