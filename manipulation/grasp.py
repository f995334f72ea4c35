"""Grasp points: where on a moving object the tool takes hold.

Objects with a handle carry a yellow knob (a visual named ``"knob"``); the
tool grasps the knob's top face at its centre, pointing down. An object
without a knob is grasped at the top centre of its collision shapes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from phyrogen_core.chain import KinematicChain, pose_matrix
from phyrogen_core.export.urdf import collision_bounds
from phyrogen_core.geometry import Box, Cylinder

from .robot import GripperSpec

KNOB_NAME = "knob"


@dataclass(frozen=True)
class GraspPoint:
    """A point in the frame of ``link`` (the object's body link)."""

    link: str
    point: tuple[float, float, float]
    on_knob: bool
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """What the fingers close on: width along the handle's x and y axes, and its height (a knob;
    an object without one: its collision bounds)."""
    yaw: float = 0.0
    """The handle's x axis, radians about the link's z axis."""

    def tool_yaw(self, link_yaw: float, preferred: float) -> float:
        """The tool yaw nearest ``preferred`` whose fingers close across a side of the handle (the
        narrower one; either of a square's), for the link turned by ``link_yaw`` in the world.

        The fingers close along the tool's y axis, which :func:`~manipulation.transforms.tool_down`
        turns to the angle ``yaw - 90 deg``."""
        axis = link_yaw + self.yaw
        width_x, width_y = self.size[:2]
        if math.isclose(width_x, width_y, rel_tol=1e-6):
            period, base = math.pi / 2, axis
        else:
            period, base = math.pi, axis + (math.pi / 2 if width_x < width_y else 0.0)
        return base + round((preferred - base) / period) * period

    @property
    def grip_width(self) -> float:
        """The width the fingers close on (the narrower side)."""
        return min(self.size[:2])


def grasp_point(chain: KinematicChain, object_name: str) -> GraspPoint:
    """The grasp point of ``object_name`` in ``chain`` (its knob's top centre when it has one)."""
    bodies = [link for link in chain.links if link.object_name == object_name and (link.visuals or link.collisions)]
    if not bodies:
        known = sorted({link.object_name for link in chain.links if link.object_name})
        raise ValueError(f"no link with geometry belongs to object {object_name!r}; objects: {known}")
    body = bodies[-1]
    for geometry in body.visuals:
        if geometry.name == KNOB_NAME and isinstance(geometry.shape, Box | Cylinder):
            if isinstance(geometry.shape, Box):
                size = tuple(float(v) for v in geometry.shape.size)
            else:
                size = (2 * geometry.shape.radius, 2 * geometry.shape.radius, geometry.shape.length)
            top = pose_matrix(geometry.origin) @ np.array([0.0, 0.0, size[2] / 2, 1.0])
            return GraspPoint(body.name, _xyz(top), True, size, float(geometry.origin.rpy[2]))  # type: ignore[arg-type]
    if not body.collisions:
        raise ValueError(f"object {object_name!r} has neither a knob nor collision shapes to grasp")
    low, high = collision_bounds(body)
    size = tuple(float(v) for v in high - low)
    return GraspPoint(body.name, ((low[0] + high[0]) / 2, (low[1] + high[1]) / 2, float(high[2])), False,
                      size)  # type: ignore[arg-type]


def _xyz(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


FINGER_MARGIN = 0.003
"""Metres the fingertips keep above whatever lies under the handle (the shaft's top)."""


def gripper_refusals(chain: KinematicChain, gripper: GripperSpec, clearance: float) -> list[str]:
    """Why the gripper cannot hold some movable object of ``chain`` (at the scene's scale), one
    line per object; empty when it holds them all. Decided from the geometry alone, before any
    simulation: a handle wider than the open fingers less ``clearance`` on each side (the room a
    grasp keeps from the puzzle), or too short for the finger pads above what lies under it."""
    problems = []
    movable = sorted({link.object_name for link in chain.links if link.object_name and any(
        j.is_active for j in chain.joints if j.child == link.name)})
    for name in movable:
        try:
            grasp = grasp_point(chain, name)
        except ValueError as exc:
            problems.append(str(exc))
            continue
        widest = gripper.stroke - 2 * clearance
        what = "handle" if grasp.on_knob else "body (it has no handle)"
        if grasp.grip_width > widest:
            problems.append(f"{name}: its {what} is {grasp.grip_width * 1000:.1f} mm wide; the gripper opens to "
                            f"{gripper.stroke * 1000:.0f} mm and needs {clearance * 1000:.0f} mm on each side "
                            f"(at most {widest * 1000:.0f} mm)")
        if grasp.size[2] < gripper.grasp_depth + FINGER_MARGIN:
            problems.append(f"{name}: its {what} is {grasp.size[2] * 1000:.1f} mm tall; the finger pads need "
                            f"{(gripper.grasp_depth + FINGER_MARGIN) * 1000:.0f} mm of it clear of what is below")
    return problems
