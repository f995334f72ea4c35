"""The dynamics the MJCF file carries: joint friction and damping, contact softness, a floor and
a position servo per movable joint, every number from a stated rule.

The file is written in the chain's units (metres, kilograms: the generators' 1 kg per object, not
the manipulation scene's wood at its scale). Per active joint, with ``M`` what the joint moves (its
child link and everything below it): the mass for a slide, the moment of inertia about its axis at
the start state for a hinge, and ``m`` that mass in both cases:

- **frictionloss** (Coulomb): ``mu m g`` for a slide, ``mu m g r`` for a hinge (a plain bearing of
  radius ``r``), with the manipulation scene's ``mu = 0.05`` and ``r = 20 mm`` (a greased slide or
  plain bearing, 0.02-0.1; docs/manipulation#physical-parameters).
- **damping** (viscous): ``M / tau`` with ``tau = 1 s``: a released part coasting at ``v`` loses
  its speed with a 1 s time constant on top of its friction (our choice: no datasheet).
- **actuator**: a ``<position>`` servo, ``kp = M w^2`` and ``kv = 2 zeta M w`` (natural frequency
  ``w = 2 pi 25 Hz``, critically damped), its force limited to :attr:`MjcfDynamics.servo_force`
  (200 N, what a Robotiq 2F-85's two pads hold at friction 1) on a slide, and to that force at the
  part's farthest collision point from the axis on a hinge. Its control range is the joint's range.
  The servo of a part nobody moves holds it where it is: that is what "left alone" means in this
  model (without it, only joint friction holds a part; scripts/mjcf_rollouts.py measures both).

Contacts (class ``collision``) are made stiff: ``solref`` of 2 ms (twice the 1 ms step, MuJoCo's
lowest stable time constant; its default is 20 ms) with MuJoCo's default ``solimp`` (0.9-0.95 over
1 mm), friction 0.5 as the manipulation scene's contacts (PyBullet's default). The constraint
solver is projected Gauss-Seidel (``PGS``, 1000 iterations, tolerance 1e-10): MuJoCo's default
Newton solver left pushes of hinged bars into each other (Grid World, Continuous Space) blowing up,
at its default iterations and at 1000 with a tolerance of 1e-12 (measured in docs/interop.md).

The floor is a plane under the lowest collision shape at the start state. The puzzle's joints carry
its parts' weight (every generator's joints move in the horizontal plane), so the floor touches no
puzzle part (its collision bits are disjoint from theirs); a body a user adds with MuJoCo's default
bits collides with the floor and with the puzzle.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..chain import Joint, JointType, KinematicChain
from .urdf import collision_bounds, link_inertia

GRAVITY = 9.81


@dataclass(frozen=True)
class MjcfDynamics:
    """The stated constants of the rules in the module's docstring."""

    timestep: float = 0.001
    """Seconds per MuJoCo step."""
    solver: str = "PGS"
    solver_iterations: int = 1000
    solver_tolerance: float = 1e-10
    """MuJoCo's projected Gauss-Seidel solver, with 1000 iterations and a tolerance of 1e-10: its
    default Newton solver (100 iterations, 1e-8), and Newton given 1000 and 1e-12, left pushes of
    hinged bars into each other blowing up (measured: docs/interop.md#dynamics)."""
    joint_friction: float = 0.05
    """Coulomb coefficient of a joint (the manipulation scene's, docs/manipulation)."""
    bearing_radius: float = 0.02
    """Metres: the radius a hinge's friction acts at."""
    damping_time: float = 1.0
    """Seconds: a joint's viscous damping is what it moves over this."""
    servo_frequency: float = 25.0
    """Hz: the natural frequency of every position servo."""
    servo_damping_ratio: float = 1.0
    servo_force: float = 200.0
    """Newtons: the most any servo applies, at the part's farthest point for a hinge (what a
    Robotiq 2F-85's pads, 2 x 100 N at friction 1, hold: docs/manipulation)."""
    contact_solref: tuple[float, float] = (0.002, 1.0)
    contact_solimp: tuple[float, float, float] = (0.9, 0.95, 0.001)
    contact_friction: tuple[float, float, float] = (0.5, 0.005, 0.0001)


DYNAMICS = MjcfDynamics()


@dataclass(frozen=True)
class JointDynamics:
    """One active joint's numbers as the file writes them."""

    name: str
    damping: float
    frictionloss: float
    kp: float
    kv: float
    force_limit: float


@dataclass(frozen=True)
class JointLoad:
    """What one active joint moves, at a state."""

    mass: float
    """Kilograms: its child link and everything below it."""
    moved: float
    """The mass for a slide; the moment of inertia about its axis (kg m^2) for a hinge."""
    reach: float
    """Metres from a hinge's axis to the farthest corner of the moved links' collision bounds (1 for
    a slide, or a hinge without shapes)."""


def joint_loads(chain: KinematicChain, start: Sequence[float] | None) -> dict[str, JointLoad]:
    """Per active joint, what it moves at ``start`` (every joint at zero clipped into its limits when None)."""
    if start is None:
        start = np.clip(np.zeros(len(chain.joint_order)), chain.lower_limits, chain.upper_limits)
    transforms = chain.link_transforms(start)
    below: dict[str, list[str]] = {}
    for joint in chain.joints:
        below.setdefault(joint.parent, []).append(joint.child)

    def subtree(link: str) -> list[str]:
        return [link, *(name for child in below.get(link, ()) for name in subtree(child))]

    out = {}
    for joint in chain.active_joints:
        links = subtree(joint.child)
        mass = sum(chain.link(name).mass for name in links)
        if joint.type is JointType.REVOLUTE:
            out[joint.name] = JointLoad(mass, _inertia_about_axis(chain, joint, links, transforms),
                                        _reach(chain, joint, links, transforms))
        else:
            out[joint.name] = JointLoad(mass, mass, 1.0)
    return out


def joint_dynamics(chain: KinematicChain, start: Sequence[float] | None,
                   dynamics: MjcfDynamics = DYNAMICS) -> dict[str, JointDynamics]:
    """Per active joint, its numbers (module docstring) at ``start`` (all joints at zero clipped
    into their limits when None)."""
    omega = 2 * math.pi * dynamics.servo_frequency
    out = {}
    for name, load in joint_loads(chain, start).items():
        friction = dynamics.joint_friction * load.mass * GRAVITY
        if chain.joint(name).type is JointType.REVOLUTE:
            friction *= dynamics.bearing_radius
        out[name] = JointDynamics(name, load.moved / dynamics.damping_time, friction, load.moved * omega ** 2,
                                  2 * dynamics.servo_damping_ratio * load.moved * omega,
                                  dynamics.servo_force * load.reach)
    return out


def floor_height(chain: KinematicChain, start: Sequence[float] | None) -> float:
    """The lowest z of any link's collision bounds at ``start`` (0 for a chain without shapes)."""
    if start is None:
        start = np.clip(np.zeros(len(chain.joint_order)), chain.lower_limits, chain.upper_limits)
    transforms = chain.link_transforms(start)
    lows = [float(_world_bounds(transforms[link.name], *collision_bounds(link))[:, 2].min())
            for link in chain.links if link.collisions]
    return min(lows, default=0.0)


def _axis_frame(joint: Joint, transforms: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The joint's axis (unit, world) and a point on it: the child frame's origin."""
    frame = transforms[joint.child]
    axis = frame[:3, :3] @ np.asarray(joint.axis, dtype=float)
    return axis / np.linalg.norm(axis), frame[:3, 3]


def _inertia_about_axis(chain: KinematicChain, joint: Joint, links: list[str],
                        transforms: dict[str, np.ndarray]) -> float:
    axis, point = _axis_frame(joint, transforms)
    total = 0.0
    for name in links:
        link = chain.link(name)
        centre, moments = link_inertia(link)
        rotation = transforms[name][:3, :3]
        local = rotation.T @ axis
        offset = transforms[name][:3, :3] @ centre + transforms[name][:3, 3] - point
        radial = offset - (offset @ axis) * axis
        total += float(local @ (np.asarray(moments) * local)) + link.mass * float(radial @ radial)
    return total


def _reach(chain: KinematicChain, joint: Joint, links: list[str], transforms: dict[str, np.ndarray]) -> float:
    """Metres from the axis to the farthest corner of the moved links' collision bounds (1 m
    without shapes, where a servo pushes nothing)."""
    axis, point = _axis_frame(joint, transforms)
    reach = 0.0
    for name in links:
        link = chain.link(name)
        if not link.collisions:
            continue
        offsets = _world_bounds(transforms[name], *collision_bounds(link)) - point
        radial = offsets - np.outer(offsets @ axis, axis)
        reach = max(reach, float(np.sqrt((radial ** 2).sum(axis=1)).max()))
    return reach if reach > 0 else 1.0


def _world_bounds(transform: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """The eight corners of a link-frame box in the world."""
    corners = np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])
    return corners @ transform[:3, :3].T + transform[:3, 3]
