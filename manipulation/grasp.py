"""Grasp points: where on a moving object the tool takes hold.

Objects with a handle carry a yellow knob (a visual named ``"knob"``); the
tool grasps the knob's top face at its centre, pointing down. An object
without a knob is grasped at the top centre of its collision shapes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from phyrogen_core.chain import KinematicChain, pose_matrix
from phyrogen_core.export.urdf import collision_bounds
from phyrogen_core.geometry import Box, Cylinder

KNOB_NAME = "knob"


@dataclass(frozen=True)
class GraspPoint:
    """A point in the frame of ``link`` (the object's body link)."""

    link: str
    point: tuple[float, float, float]
    on_knob: bool


def grasp_point(chain: KinematicChain, object_name: str) -> GraspPoint:
    """The grasp point of ``object_name`` in ``chain`` (its knob's top centre when it has one)."""
    bodies = [link for link in chain.links if link.object_name == object_name and (link.visuals or link.collisions)]
    if not bodies:
        known = sorted({link.object_name for link in chain.links if link.object_name})
        raise ValueError(f"no link with geometry belongs to object {object_name!r}; objects: {known}")
    body = bodies[-1]
    for geometry in body.visuals:
        if geometry.name == KNOB_NAME and isinstance(geometry.shape, Box | Cylinder):
            height = geometry.shape.size[2] if isinstance(geometry.shape, Box) else geometry.shape.length
            top = pose_matrix(geometry.origin) @ np.array([0.0, 0.0, height / 2, 1.0])
            return GraspPoint(body.name, _xyz(top), True)
    if not body.collisions:
        raise ValueError(f"object {object_name!r} has neither a knob nor collision shapes to grasp")
    low, high = collision_bounds(body)
    return GraspPoint(body.name, ((low[0] + high[0]) / 2, (low[1] + high[1]) / 2, float(high[2])), False)


def _xyz(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))
