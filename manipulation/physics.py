"""The puzzle's physical parameters in the simulation: masses from volume, joint friction from mass.

The generators give every object a mass of 1 kg whatever its size (a 1.2 m Continuous Space bar
and a 6 mm Rooms block alike). The scene gives each link with collision shapes the mass of its
shapes' volume at :attr:`PuzzleMaterial.density` (at the scene's scale); the URDF's inertia is
then the core's :func:`~phyrogen_core.export.urdf.link_inertia` (a solid box of that mass over
the link's collision bounds). Each puzzle joint resists with Coulomb friction from the mass it
moves: ``mu m g`` for a slide, ``mu m g r`` for a hinge (a bearing of radius ``r``), applied as
PyBullet's zero-velocity motor with that force, so a released object stays where it was left.
Every number and its source: docs/manipulation/README.md#physical-parameters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from phyrogen_core.chain import JointType, KinematicChain
from phyrogen_core.geometry import Box, ConvexPrism, Cylinder, Shape

GRAVITY = 9.81


@dataclass(frozen=True)
class PuzzleMaterial:
    density: float = 500.0
    """kg/m^3: softwood (pine, 350-550 kg/m^3), the puzzle's pieces as solid wood."""
    joint_friction: float = 0.05
    """Coulomb coefficient of the puzzle's joints (a greased slide or plain bearing, 0.02-0.1)."""
    bearing_radius: float = 0.02
    """Metres: the radius a hinge's friction acts at."""
    joint_damping: float = 0.0
    """N s/m (or N m s/rad) of viscous damping in the puzzle's joints: none, friction alone."""

    def __post_init__(self) -> None:
        for name in ("density", "joint_friction", "bearing_radius", "joint_damping"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"puzzle material {name} must be a finite number >= 0, got {value!r}")


def shape_volume(shape: Shape) -> float:
    """Cubic metres of one collision shape."""
    if isinstance(shape, Box):
        return float(shape.size[0] * shape.size[1] * shape.size[2])
    if isinstance(shape, Cylinder):
        return float(math.pi * shape.radius ** 2 * shape.length)
    if isinstance(shape, ConvexPrism):
        area = 0.0
        for piece in shape.pieces:
            area += 0.5 * abs(sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(piece, piece[1:] + piece[:1],
                                                                                   strict=True)))
        return float(area * shape.height)
    raise TypeError(f"unsupported shape {type(shape).__name__}; valid: Box, Cylinder, ConvexPrism")


def with_masses(chain: KinematicChain, material: PuzzleMaterial) -> KinematicChain:
    """The chain with every link that has collision shapes weighing their volume at the material's
    density (shapes of one link are taken not to overlap: a body, its handle's shaft and knob);
    links without shapes (an SE(2) object's helper links, the root) keep their mass."""
    links = tuple(replace(link, mass=material.density * sum(shape_volume(g.shape) for g in link.collisions))
                  if link.collisions else link for link in chain.links)
    return KinematicChain(links, chain.joints, chain.root, chain.name)


def joint_friction(chain: KinematicChain, material: PuzzleMaterial) -> dict[str, float]:
    """Per active joint: the force (N) or torque (N m) its friction resists with, from the mass
    it moves (its child link and everything below it)."""
    below: dict[str, list[str]] = {}
    for joint in chain.joints:
        below.setdefault(joint.parent, []).append(joint.child)

    def moved_mass(link: str) -> float:
        return chain.link(link).mass + sum(moved_mass(child) for child in below.get(link, ()))

    out = {}
    for joint in chain.active_joints:
        force = material.joint_friction * moved_mass(joint.child) * GRAVITY
        out[joint.name] = force * material.bearing_radius if joint.type is JointType.REVOLUTE else force
    return out
