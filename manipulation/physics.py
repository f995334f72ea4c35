"""The puzzle's physical parameters in the simulation: masses from a stated material, joint friction
and damping from the mass each joint moves.

The generators give every object a mass of 1 kg whatever its size (a 1.2 m Continuous Space bar
and a 6 mm Rooms block alike). The scene builds each piece as a hollow box of plywood panels
(:class:`PuzzleMaterial`): a link with collision shapes weighs, per shape, the material's density
times the smaller of the shape's volume and its surface times the panel thickness (a small part,
a knob, is solid wood), at the scene's scale; the URDF's inertia is then the core's
:func:`~phyrogen_core.export.urdf.link_inertia` (a solid box of that mass over the link's collision
bounds). Each puzzle joint resists with Coulomb friction from the mass it moves: ``mu m g`` for a
slide, ``mu m g r`` for a hinge (a bearing of radius ``r``), applied as PyBullet's zero-velocity
motor with that force, so a released object stays where it was left; and with viscous damping
``M / tau`` (``M`` the moved mass, or the moment of inertia about a hinge's axis), the MJCF
export's rule (:mod:`phyrogen_core.export.mjcf_dynamics`).
Every number and its source: docs/manipulation/README.md#physical-parameters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from phyrogen_core.chain import JointType, KinematicChain
from phyrogen_core.export.mjcf_dynamics import joint_loads
from phyrogen_core.geometry import Box, ConvexPrism, Cylinder, Shape

GRAVITY = 9.81


@dataclass(frozen=True)
class PuzzleMaterial:
    density: float = 650.0
    """kg/m^3: birch plywood (630-700 kg/m^3)."""
    panel: float = 0.012
    """Metres: the plywood's thickness; a piece is a hollow box of such panels (a part thinner than
    two panels, a knob, is solid)."""
    joint_friction: float = 0.05
    """Coulomb coefficient of the puzzle's joints (a greased slide or plain bearing, 0.02-0.1)."""
    bearing_radius: float = 0.02
    """Metres: the radius a hinge's friction acts at."""
    damping_time: float = 1.0
    """Seconds: a joint's viscous damping is what it moves over this (the MJCF export's rule: a
    released part loses its speed with this time constant on top of its friction)."""

    def __post_init__(self) -> None:
        for name in ("density", "panel", "joint_friction", "bearing_radius", "damping_time"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"puzzle material {name} must be a finite number >= 0, got {value!r}")
        if self.damping_time == 0:
            raise ValueError("puzzle material damping_time must be > 0, got 0")


def shape_volume(shape: Shape) -> float:
    """Cubic metres of one collision shape (solid)."""
    return _volume_and_surface(shape)[0]


def shell_volume(shape: Shape, panel: float) -> float:
    """Cubic metres of material in the shape built of panels ``panel`` thick: its surface times
    the panel, at most its solid volume."""
    volume, surface = _volume_and_surface(shape)
    return min(volume, surface * panel)


def _volume_and_surface(shape: Shape) -> tuple[float, float]:
    if isinstance(shape, Box):
        a, b, c = (float(v) for v in shape.size)
        return a * b * c, 2 * (a * b + b * c + c * a)
    if isinstance(shape, Cylinder):
        r, length = float(shape.radius), float(shape.length)
        return math.pi * r * r * length, 2 * math.pi * r * (r + length)
    if isinstance(shape, ConvexPrism):
        area = perimeter = 0.0
        for piece in shape.pieces:
            edges = list(zip(piece, piece[1:] + piece[:1], strict=True))
            area += 0.5 * abs(sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in edges))
            perimeter += sum(math.dist(p, q) for p, q in edges)
        return area * shape.height, 2 * area + perimeter * shape.height
    raise TypeError(f"unsupported shape {type(shape).__name__}; valid: Box, Cylinder, ConvexPrism")


def with_masses(chain: KinematicChain, material: PuzzleMaterial) -> KinematicChain:
    """The chain with every link that has collision shapes weighing its shapes' material
    (:func:`shell_volume`) at the material's density (shapes of one link are taken not to overlap:
    a body, its handle's shaft and knob); links without shapes (an SE(2) object's helper links,
    the root) keep their mass."""
    links = tuple(replace(link, mass=material.density * sum(shell_volume(g.shape, material.panel)
                                                            for g in link.collisions))
                  if link.collisions else link for link in chain.links)
    return KinematicChain(links, chain.joints, chain.root, chain.name)


def joint_friction(chain: KinematicChain, material: PuzzleMaterial) -> dict[str, float]:
    """Per active joint: the force (N) or torque (N m) its friction resists with, from the mass
    it moves (its child link and everything below it)."""
    out = {}
    for name, load in joint_loads(chain, None).items():
        force = material.joint_friction * load.mass * GRAVITY
        out[name] = force * material.bearing_radius if chain.joint(name).type is JointType.REVOLUTE else force
    return out


def joint_damping(chain: KinematicChain, material: PuzzleMaterial) -> dict[str, float]:
    """Per active joint: its viscous damping, N s/m (slide) or N m s/rad (hinge): what it moves
    (mass, or moment of inertia about the axis with every joint at zero) over the material's
    :attr:`~PuzzleMaterial.damping_time`."""
    return {name: load.moved / material.damping_time for name, load in joint_loads(chain, None).items()}
