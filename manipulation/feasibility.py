"""Whether a friction grasp can move a puzzle: per movable part, its mass in the manipulation scene and
the force the gripper's pads must pass to it, against what they hold (no simulation).

Per movable part and joint, the force at the grasp point (its knob's top) to overcome the joint's
friction and accelerate the part at :data:`ACCELERATION` (the follower's ramp: 0.25 m/s reached in
0.25 s, :attr:`~manipulation.following.FollowSettings.ramp`):

- a slide: ``mu m g + m a``;
- a hinge: ``mu m g r / R + I a / R^2`` (bearing radius r, grasp point R from the axis, I the
  moment of inertia about the axis);

the part's figure is the largest over its joints (an SE(2) part: x, y and yaw). Two pads pressed
with ``F`` each hold ``2 mu_pad F`` along the handle: 470 N for a Robotiq 2F-85 at its largest force
(235 N) and pad friction 1. **The bound** every part of a puzzle must keep (:func:`grip_bound`): at
most an eighth of that, 59 N, leaving the rest to the follower's tracking error and stops, a wall's
friction and the damping of the part's joint (docs/manipulation/README.md#physical-parameters). The
earlier solid pine (500 kg/m^3) broke it: Continuous Space bars 66 N, Lockbox discs up to 112 N.
"""

from __future__ import annotations

import numpy as np

from phyrogen_core.chain import JointType
from phyrogen_core.export.mjcf_dynamics import joint_loads

from .grasp import grasp_point
from .physics import GRAVITY, PuzzleMaterial, with_masses
from .placement import joint_value_scale, physical_scale, scale_chain
from .robot import GripperSpec

ACCELERATION = 1.0
"""m/s^2 at the grasp point: the follower's ramp (0.25 m/s in 0.25 s)."""
GRIP_MARGIN = 8.0
"""What the pads hold over what a part may need (:func:`grip_bound`)."""


def grip_hold(gripper: GripperSpec) -> float:
    """Newtons the two pads hold along the handle by friction: ``2 mu_pad F``."""
    return 2 * gripper.pad_friction * gripper.grip_force


def grip_bound(gripper: GripperSpec) -> float:
    """Newtons any part may need at its grasp point: the pads' hold over :data:`GRIP_MARGIN`."""
    return grip_hold(gripper) / GRIP_MARGIN


def part_forces(generator: str, chain, start, material: PuzzleMaterial | None = None) -> dict[str, tuple]:
    """Per movable part: (mass kg, force N at its grasp point, the joint that needs it)."""
    material = PuzzleMaterial() if material is None else material
    scale = physical_scale(generator)
    scaled = with_masses(scale_chain(chain, scale), material)
    state = np.asarray(start, dtype=float) * joint_value_scale(chain, scale)
    transforms = scaled.link_transforms(state)
    loads = joint_loads(scaled, state)
    out: dict[str, tuple] = {}
    for joint in scaled.active_joints:
        part = scaled.object_of_joint(joint.name)
        load = loads[joint.name]
        grasp = grasp_point(scaled, part)
        at = (transforms[grasp.link] @ np.array([*grasp.point, 1.0]))[:3]
        if joint.type is JointType.REVOLUTE:
            frame = transforms[joint.child]
            axis = frame[:3, :3] @ np.asarray(joint.axis, dtype=float)
            offset = at - frame[:3, 3]
            radius = float(np.linalg.norm(offset - (offset @ axis) * axis))
            if radius < 1e-6:  # a grasp on the axis turns the part by a torque of the pads, not a force
                continue
            force = (material.joint_friction * load.mass * GRAVITY * material.bearing_radius / radius
                     + load.moved * ACCELERATION / radius ** 2)
        else:
            force = material.joint_friction * load.mass * GRAVITY + load.mass * ACCELERATION
        part_mass = sum(link.mass for link in scaled.links if link.object_name == part)
        if part not in out or force > out[part][1]:
            out[part] = (part_mass, force, joint.name)
    return out
